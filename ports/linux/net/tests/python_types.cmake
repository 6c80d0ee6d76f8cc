# ctest lcm_python_decodes_fused (included from ports/linux/net/CMakeLists.txt):
# the generated C type encodes a fused_t (fused_dump), the generated Python
# type decodes it and indexes contributed[0] (lcm_fused_decode.py).
add_executable(fused_dump ${CMAKE_CURRENT_LIST_DIR}/fused_dump.c)
target_compile_options(fused_dump PRIVATE ${DKF_WARNINGS})
target_link_libraries(fused_dump PRIVATE dkf_lcm_types)
add_test(NAME lcm_python_decodes_fused
  COMMAND sh -c "\"$1\" \"$2\" && \"$3\" \"$4\" \"$5\" \"$2\"" sh
          $<TARGET_FILE:fused_dump> ${CMAKE_CURRENT_BINARY_DIR}/fused_t.bin
          ${Python3_EXECUTABLE} ${CMAKE_CURRENT_LIST_DIR}/lcm_fused_decode.py ${DKF_LCM_PYTHON_DIR})
set_tests_properties(lcm_python_decodes_fused PROPERTIES TIMEOUT 30 PASS_REGULAR_EXPRESSION "^PASS"
  REQUIRED_FILES ${DKF_LCM_PYTHON_DIR}/dkf_lcm/fused_t.py)
