# Runs the request fuzzer for a bounded, seeded number of inputs from a fresh corpus seeded with
# the golden PlanJumpRequest. Fails if the fuzzer finds a crash or an invariant break.
if(NOT EXISTS ${FUZZER})
  message(FATAL_ERROR "fuzzer ${FUZZER} not built: cmake --build <dir> --target wj_server_fuzz")
endif()
file(REMOVE_RECURSE ${WORK_DIR})
file(MAKE_DIRECTORY ${WORK_DIR}/corpus)
file(COPY ${SEED_INPUT} DESTINATION ${WORK_DIR}/corpus)
execute_process(
  COMMAND ${FUZZER} -runs=20000 -seed=1 -max_len=4096 -max_total_time=120
    -artifact_prefix=${WORK_DIR}/ ${WORK_DIR}/corpus
  WORKING_DIRECTORY ${WORK_DIR}
  RESULT_VARIABLE result)
if(NOT result EQUAL 0)
  message(FATAL_ERROR "the fuzzer failed (exit ${result}); reproducer in ${WORK_DIR}")
endif()
