# cmake -P script behind the `public_headers_extern_c` test
# (tests/cxx/CMakeLists.txt): every header in DKF_INCLUDE_DIR, and the
# template DKF_BUILD_CONFIG_IN of the generated dkf/build_config.h, must
# open an extern "C" block for C++ after its #includes and close it before
# its last #endif, unless it holds nothing but preprocessor lines and
# comments (then a C++ compiler has nothing to give C linkage to).
cmake_minimum_required(VERSION 3.25)
set(open_re "\n#ifdef __cplusplus\nextern \"C\" {\n#endif\n")
set(close_re "\n#ifdef __cplusplus\n}\n#endif\n\n#endif [^\n]*\n$")
file(GLOB headers ${DKF_INCLUDE_DIR}/*.h)
set(bad)
set(exempt)
foreach(h IN LISTS headers DKF_BUILD_CONFIG_IN)
  file(READ ${h} text)
  # Comments out, then every line that is not a directive (nor blank).
  string(REGEX REPLACE "/[*]([^*]|[*]+[^*/])*[*]+/" "" code "${text}")
  string(REGEX REPLACE "(^|\n)[ \t]*#[^\n]*" "" code "${code}")
  string(STRIP "${code}" code)
  get_filename_component(name ${h} NAME)
  if(code STREQUAL "")
    list(APPEND exempt ${name})
  elseif(NOT text MATCHES "${open_re}" OR NOT text MATCHES "${close_re}")
    list(APPEND bad ${name})
  endif()
endforeach()
if(bad)
  message(FATAL_ERROR "public_headers_extern_c: no extern \"C\" guards (#ifdef __cplusplus "
    "extern \"C\" { #endif after the #includes, the closing block before the last #endif) in: "
    "${bad}")
endif()
list(LENGTH headers n)
message(STATUS "public_headers_extern_c: ${n} headers and build_config.h.in: guarded, or "
  "preprocessor lines only (${exempt}): ok")
