# cmake/sources.cmake - the core's C sources, as absolute paths in
# DKF_CORE_SOURCES: the one list that the library (CMakeLists.txt) and the
# Python package's two builds of it (python/CMakeLists.txt) compile.
set(DKF_CORE_SOURCES
  status.c
  version.c
  check.c
  kernels.c
  kernels_avx.c
  kf_avx.c
  mat.c
  mat_chol.c
  mat_lu.c
  mat_qr.c
  mat_svd.c
  mat_riccati.c
  kf.c
  info.c
  diffkf.c
  diffkf_fusion.c
  diffkf_fusion_ckpt.c
  diffkf_fusion_msg.c
  askf.c
  otskf.c
  graph.c
  tw.c
  uif.c
  nl_model.c
  nerts.c
  nerts_stack.c
  dfnerts.c
  wfusion.c
  selftune.c
)
list(TRANSFORM DKF_CORE_SOURCES PREPEND ${CMAKE_CURRENT_LIST_DIR}/../src/)
