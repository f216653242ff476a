# Checks that an object file compiled for a wider instruction set than the rest of the program
# (fit/src/kernels/avx2.cpp, with -mavx2 -mfma) is isolated: its one global definition is the
# symbol named, and it defines nothing weak. A weak definition (W, V, or u: the inline and template
# functions of Eigen or the standard library) may be the copy the linker keeps for every caller,
# and would then run AVX instructions on any processor. Nor may it run anything when the program
# loads (a dynamic initialiser, listed in .init_array or .ctors), which would run whatever the
# processor, before the dispatch could choose. Also checks that the object does use the
# wider registers and that BASELINE_OBJECT (the same code for any processor) does not: the
# per-file flags took effect.
# Usage: cmake -DNM=nm -DOBJDUMP=objdump -DOBJECT=avx2.o -DBASELINE_OBJECT=generic.o
#              -DONLY_GLOBAL=symbol -DREGISTER=ymm -P check_isolated_object.cmake
foreach(variable NM OBJDUMP OBJECT BASELINE_OBJECT ONLY_GLOBAL REGISTER)
  if(NOT DEFINED ${variable} OR "${${variable}}" STREQUAL "")
    message(FATAL_ERROR "check_isolated_object: ${variable} is not set")
  endif()
endforeach()
foreach(object "${OBJECT}" "${BASELINE_OBJECT}")
  if(NOT EXISTS "${object}")
    message(FATAL_ERROR "check_isolated_object: no object file ${object}")
  endif()
endforeach()

execute_process(COMMAND "${NM}" -C "${OBJECT}" OUTPUT_VARIABLE symbols RESULT_VARIABLE failed)
if(failed)
  message(FATAL_ERROR "check_isolated_object: ${NM} failed on ${OBJECT}")
endif()
string(REPLACE "\n" ";" lines "${symbols}")
set(found_only_global FALSE)
set(offending "")
foreach(line IN LISTS lines)
  # "address type name" for definitions, "type name" (after spaces) for references.
  if(NOT line MATCHES "^[0-9a-f ]* ([A-Za-z]) (.*)$")
    continue()
  endif()
  set(type "${CMAKE_MATCH_1}")
  set(name "${CMAKE_MATCH_2}")
  # The sanitizers' own bookkeeping, in the instrumented build only.
  if(name MATCHES "^_*(asan|ubsan|sanitizer|odr_asan)")
    continue()
  endif()
  if(type MATCHES "^[WVu]$")
    list(APPEND offending "weak ${type} ${name}")
  elseif(type MATCHES "^[A-TX-Z]$" AND NOT type STREQUAL "U")
    if(name STREQUAL ONLY_GLOBAL)
      set(found_only_global TRUE)
    else()
      list(APPEND offending "global ${type} ${name}")
    endif()
  endif()
endforeach()
if(NOT found_only_global)
  message(FATAL_ERROR "${OBJECT} does not define ${ONLY_GLOBAL}:\n${symbols}")
endif()

# Code run at load: the sections of initialisers, and what each entry points to. Priorities up to
# 100 are reserved for the implementation (GCC warns for the project's own, and warnings are
# errors): there the sanitizers' and coverage's module constructors register the object with
# their run-time (instrumented builds only), and they are the only entries allowed.
execute_process(COMMAND "${OBJDUMP}" -h "${OBJECT}" OUTPUT_VARIABLE headers RESULT_VARIABLE failed)
if(failed)
  message(FATAL_ERROR "check_isolated_object: ${OBJDUMP} -h failed on ${OBJECT}")
endif()
string(REGEX MATCHALL "[.](preinit_array|init_array|ctors)[.0-9]*" load_sections "${headers}")
list(REMOVE_DUPLICATES load_sections)
foreach(section IN LISTS load_sections)
  if(section MATCHES "[.]([0-9]+)$" AND CMAKE_MATCH_1 LESS_EQUAL 100)
    continue()
  endif()
  execute_process(COMMAND "${OBJDUMP}" -r -j "${section}" "${OBJECT}" OUTPUT_VARIABLE entries RESULT_VARIABLE failed)
  if(failed)
    message(FATAL_ERROR "check_isolated_object: ${OBJDUMP} -r failed on ${OBJECT}")
  endif()
  string(REGEX MATCHALL "R_[A-Z0-9_]+ +[^\n]+" targets "${entries}")
  foreach(target IN LISTS targets)
    list(APPEND offending "run at load (${section}): ${target}")
  endforeach()
endforeach()
if(offending)
  list(JOIN offending "\n  " listed)
  message(FATAL_ERROR "${OBJECT} is not isolated:\n  ${listed}")
endif()

function(count_register object result)
  execute_process(COMMAND "${OBJDUMP}" -d "${object}" OUTPUT_VARIABLE code RESULT_VARIABLE failed)
  if(failed)
    message(FATAL_ERROR "check_isolated_object: ${OBJDUMP} failed on ${object}")
  endif()
  string(REGEX MATCHALL "%${REGISTER}[0-9]+" uses "${code}")
  list(LENGTH uses count)
  set(${result} ${count} PARENT_SCOPE)
endfunction()
count_register("${OBJECT}" wide)
count_register("${BASELINE_OBJECT}" baseline)
if(wide EQUAL 0)
  message(FATAL_ERROR "${OBJECT} uses no ${REGISTER} register: was it compiled with its flags?")
endif()
if(NOT baseline EQUAL 0)
  message(FATAL_ERROR "${BASELINE_OBJECT} uses ${REGISTER} registers (${baseline} times): it must run anywhere")
endif()
message(STATUS "${OBJECT}: only ${ONLY_GLOBAL} global, nothing weak, nothing run at load, ${wide} uses of ${REGISTER}")
