#pragma once
// Counts heap allocations (global operator new) while enabled, so tests can
// show that a warm step allocates nothing. Replaces the global operator new
// and delete of the test executable (in allocation_counter.cpp, a separate
// translation unit so the compiler never inlines them into allocating code).

namespace palpa::test {

/// Starts counting from zero.
void start_counting_allocations();
/// Stops counting and returns the allocations since start_counting_allocations().
long stop_counting_allocations();

}  // namespace palpa::test
