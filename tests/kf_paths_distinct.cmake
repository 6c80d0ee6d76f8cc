# cmake -DNM=<nm> -DFIXED=<exe> -DGENERIC=<exe> -P kf_paths_distinct.cmake
#
# Passes only if dkf__kf_predict_isa and dkf__kf_update_isa (the baseline
# steps behind dkf_kf_predict and dkf_kf_update) and dkf_diffkf_step are
# all larger in the FIXED executable than in GENERIC: the fixed-size steps
# are forced inline into them, so equal sizes mean both programs carry the
# same build of the step and kf_paths_identical would compare a build with
# itself.
if(NOT NM)
  message(FATAL_ERROR "no nm (CMAKE_NM) to inspect the executables with")
endif()

# The size of sym in exe, with the parts GCC may split off it (sym.part.0,
# sym.cold, ...: the step's body moves there when only a dispatch is left).
function(sym_size exe sym out)
  execute_process(COMMAND ${NM} -S --defined-only ${exe} OUTPUT_VARIABLE o RESULT_VARIABLE rc)
  string(REGEX MATCHALL "[0-9a-fA-F]+ [0-9a-fA-F]+ [Tt] ${sym}(\\.[a-z]+(\\.[0-9]+)?)?\n" lines "${o}")
  if(NOT rc EQUAL 0 OR NOT lines)
    message(FATAL_ERROR "${NM} finds no sized symbol ${sym} in ${exe}")
  endif()
  set(s 0)
  foreach(l ${lines})
    string(REGEX MATCH "^[0-9a-fA-F]+ ([0-9a-fA-F]+)" _ "${l}")
    math(EXPR s "${s} + 0x${CMAKE_MATCH_1}")
  endforeach()
  set(${out} ${s} PARENT_SCOPE)
endfunction()

foreach(sym dkf__kf_predict_isa dkf__kf_update_isa dkf_diffkf_step)
  sym_size(${FIXED} ${sym} f)
  sym_size(${GENERIC} ${sym} g)
  message("${sym}: ${f} bytes with fixed sizes, ${g} generic")
  if(NOT f GREATER g)
    message(FATAL_ERROR "${sym} is not larger with fixed sizes: the two builds do not differ")
  endif()
endforeach()
