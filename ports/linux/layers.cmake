# The host layer rules, checked (docs/layout.md, "Host layers"; decision 40).
# Labels build and once (cmake/testing.cmake): they check the sources and
# the libraries' names, whatever the configuration.

# Every static library built under ports/linux (the layers, net's, their
# generated message types): the host symbols tools/check_layers.py checks.
function(dkf_host_libraries dir out)
  get_property(_targets DIRECTORY ${dir} PROPERTY BUILDSYSTEM_TARGETS)
  get_property(_subdirs DIRECTORY ${dir} PROPERTY SUBDIRECTORIES)
  set(_libs)
  foreach(t ${_targets})
    get_target_property(_type ${t} TYPE)
    if(_type STREQUAL "STATIC_LIBRARY")
      list(APPEND _libs $<TARGET_FILE:${t}>)
    endif()
  endforeach()
  foreach(d ${_subdirs})
    dkf_host_libraries(${d} _sub)
    list(APPEND _libs ${_sub})
  endforeach()
  set(${out} ${_libs} PARENT_SCOPE)
endfunction()
dkf_host_libraries(${CMAKE_CURRENT_SOURCE_DIR} _host_libs)

# Includes only downward, no cycle between folders, at most 15 C files a
# folder, no host symbol with a core module prefix.
add_test(NAME host_layers
  COMMAND ${Python3_EXECUTABLE} ${PROJECT_SOURCE_DIR}/tools/check_layers.py
          ${CMAKE_CURRENT_SOURCE_DIR} --core $<TARGET_FILE:dkf>
          --core-include ${PROJECT_SOURCE_DIR}/include/dkf ${_host_libs})
set_tests_properties(host_layers PROPERTIES TIMEOUT 60 PASS_REGULAR_EXPRESSION "check_layers: OK")

# The build refuses an upward include: a file compiled as part of layer L
# that includes the first header of the layer above L does not find it,
# nor a header in another layer's private/ folder. (The compiler's own
# message, so a probe that fails for another reason does not pass.)
set(_probe_dir ${CMAKE_CURRENT_BINARY_DIR}/layer-probes)
set(_probes)
# dkf_host_probe(<name> <layer target> <header>)
function(dkf_host_probe name target header)
  file(WRITE ${_probe_dir}/${name}.c "#include \"${header}\"\nint dkf_host_${name};\n")
  add_library(dkf_host_${name} OBJECT EXCLUDE_FROM_ALL ${_probe_dir}/${name}.c)
  target_link_libraries(dkf_host_${name} PRIVATE ${target})
  add_test(NAME host_${name}
    COMMAND ${CMAKE_COMMAND} --build ${CMAKE_BINARY_DIR} --target dkf_host_${name})
  set_tests_properties(host_${name} PROPERTIES TIMEOUT 120 RESOURCE_LOCK dkf_build_dir
    PASS_REGULAR_EXPRESSION "(${header}: No such file|'${header}' file not found)")
  set(_probes ${_probes} host_${name} PARENT_SCOPE)
endfunction()
set(_below)
foreach(_layer ${DKF_HOST_LAYERS})
  file(GLOB _headers RELATIVE ${CMAKE_CURRENT_SOURCE_DIR}/${_layer}
       ${CMAKE_CURRENT_SOURCE_DIR}/${_layer}/*.h)
  if(_below AND _headers)
    list(SORT _headers)
    list(GET _headers 0 _header)
    dkf_host_probe(upward_${_below} dkf_host_${_below} ${_header})
  endif()
  if(TARGET dkf_host_${_layer})
    set(_below ${_layer})
  endif()
endforeach()
dkf_host_probe(private_scn_parse dkf_host_models scn_parse.h)
dkf_label_tests(build once TESTS host_layers ${_probes})
