# Stability suite and work-precision sweep (docs/stability.md). Included from CMakeLists.txt.
lockroll_add_test(stability_test stability_test.cpp)
target_link_libraries(stability_test PRIVATE lockroll_harness)

# Every case of `lockroll stability` is its own test, so a failure names the case. The default
# run (scripts/test.sh: -LE soak) takes a few seconds; the 10,000-body case is labelled soak.
foreach(case free_fall bounce head_on newton_cradle stacks mass_ratio overlap_spawn tunneling far_origin
        tiny_huge q32_limits paper_sweep resting_pile rigid_roll rigid_backspin rigid_spin
        rigid_ramp rigid_tip rigid_pyramid rigid_stack)
  add_test(NAME stability_${case} COMMAND lockroll stability --case ${case})
  set_tests_properties(stability_${case} PROPERTIES LABELS "unit;stability" TIMEOUT 120)
endforeach()
add_test(NAME stability_dense_chaos COMMAND lockroll stability --case dense_chaos)
set_tests_properties(stability_dense_chaos PROPERTIES LABELS "soak;stability" TIMEOUT 600)

# The sweep end to end on a small grid (CSV only; the plot script is exercised by the soak run).
add_test(NAME precision_quick COMMAND lockroll precision --quick --no-plot --reps 1
         --out ${CMAKE_CURRENT_BINARY_DIR}/precision_quick)
set_tests_properties(precision_quick PROPERTIES LABELS "unit;stability" TIMEOUT 120)
add_test(NAME precision_full COMMAND lockroll precision --out ${CMAKE_CURRENT_BINARY_DIR}/precision_full)
set_tests_properties(precision_full PROPERTIES LABELS "soak;stability" TIMEOUT 1800 ENVIRONMENT MPLBACKEND=Agg)
