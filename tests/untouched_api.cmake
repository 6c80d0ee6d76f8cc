# cmake -DINC=<include dir> -DOUT=<header> -P untouched_api.cmake
#
# Writes OUT for tests/test_error_untouched.c: the public functions of
# INC/dkf/*.h that take a filter object, which the untouched-on-failure
# sweep must exercise. A filter object is a type that a DKF_*_DECLARE
# macro binds to storage (its last line "sc <type> name"); a function
# takes one when a parameter is a pointer to (or an array of) such a type.
# OUT holds, for every such function, a line
#     DKF_UNTOUCHED_API(name, returns_status)
# of the list DKF_UNTOUCHED_API_LIST, and for each that returns a
# dkf_status_t a macro of its own name that calls it and passes the name
# and the status to untouched_note() (defined by the test), so every call
# the test makes is recorded.
if(NOT INC OR NOT OUT)
  message(FATAL_ERROR "usage: cmake -DINC=<include dir> -DOUT=<header> -P untouched_api.cmake")
endif()

file(GLOB headers "${INC}/dkf/*.h")
set(text "")
foreach(h ${headers})
  file(READ "${h}" s)
  string(APPEND text "${s}\n")
endforeach()
# CMake lists split at ';' and treat '[' ']' specially: neither may stay
string(REPLACE ";" "@" text "${text}")
string(REPLACE "[" "<" text "${text}")
string(REPLACE "]" ">" text "${text}")

string(REGEX MATCHALL "\n *sc dkf_[a-z0-9_]+_t name\n" decl_lines "${text}")
set(types "")
foreach(l ${decl_lines})
  string(REGEX MATCH "dkf_[a-z0-9_]+_t" t "${l}")
  list(APPEND types ${t})
endforeach()
list(REMOVE_DUPLICATES types)
list(LENGTH types ntypes)
if(ntypes LESS 10)
  message(FATAL_ERROR "untouched_api: only ${ntypes} filter object types found in ${INC}/dkf")
endif()

string(REGEX MATCHALL "\n[a-z_ ]*[a-z_] \\**dkf_[a-z0-9_]+\\([^@]*\\)@" decls "${text}")
set(list_lines "")
set(macros "")
set(count 0)
foreach(d ${decls})
  string(REGEX MATCH "(dkf_[a-z0-9_]+)\\(([^@]*)\\)@" _ "${d}")
  set(name "${CMAKE_MATCH_1}")
  set(params "${CMAKE_MATCH_2}")
  set(takes 0)
  foreach(t ${types})
    if(params MATCHES "(^|[^a-z0-9_])${t} *(\\*|[a-z0-9_]+ *<>)")
      set(takes 1)
    endif()
  endforeach()
  if(takes)
    if(d MATCHES "^\n *dkf_status_t ")
      set(status 1)
      string(APPEND macros
        "#define ${name}(...) untouched_note(\"${name}\", (${name})(__VA_ARGS__))\n")
    else()
      set(status 0)
    endif()
    string(APPEND list_lines "    DKF_UNTOUCHED_API(${name}, ${status}) \\\n")
    math(EXPR count "${count} + 1")
  endif()
endforeach()
if(count LESS 50)
  message(FATAL_ERROR "untouched_api: only ${count} functions taking an object found")
endif()

file(WRITE "${OUT}.tmp"
  "/* Written by tests/untouched_api.cmake from the public headers (dkf/):\n"
  " * the ${count} functions that take a filter object. Do not edit. */\n"
  "#define DKF_UNTOUCHED_API_LIST \\\n${list_lines}\n\n${macros}")
# rewritten only when it changes: the test is not rebuilt for nothing
execute_process(COMMAND ${CMAKE_COMMAND} -E copy_if_different "${OUT}.tmp" "${OUT}")
file(REMOVE "${OUT}.tmp")
