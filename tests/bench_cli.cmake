# `dypho bench simple-trainer` with bad arguments (issue 20): each exits
# non-zero and its error names the argument. PASS_REGULAR_EXPRESSION alone
# would ignore the exit status, so the shell checks both. Included from
# tests/CMakeLists.txt.
set(DYPHO_BENCH_BAD_ARGS
  "unknown_optimizer|--optimizer adamw|--optimizer: adamw not in"
  "zero_iters|--iters 0|--iters: Value 0 not in range 1 to"
  "non_number_iters|--iters ten|--iters: Value ten"
  "negative_warmup|--warmup -1|--warmup: Value -1 not in range 0 to"
  "zero_lr|--lr 0|--lr: Value 0"
  "unknown_option|--iterations 5|--iterations")
foreach(entry ${DYPHO_BENCH_BAD_ARGS})
  string(REPLACE "|" ";" parts "${entry}")
  list(GET parts 0 name)
  list(GET parts 1 args)
  list(GET parts 2 expected)
  add_test(NAME BenchSimpleTrainerBadArgs_${name}
    COMMAND sh -c "out=$($<TARGET_FILE:dypho> bench simple-trainer --synthetic --gaussians 10 ${args} 2>&1); \
rc=$?; printf '%s\\n' \"$out\"; echo \"exit status $rc\"; \
[ $rc -ne 0 ] && printf '%s\\n' \"$out\" | grep -q -F -e '${expected}'")
  set_tests_properties(BenchSimpleTrainerBadArgs_${name} PROPERTIES TIMEOUT 60)
endforeach()
