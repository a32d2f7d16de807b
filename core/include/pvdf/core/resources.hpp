// What the running process has used: its peak resident memory (for the `--json` of long commands).
#pragma once

#include <cstdint>

namespace pvdf {

/// The largest resident set size of this process so far, in bytes (getrusage's ru_maxrss; 0 when
/// the system does not say). Children are not counted.
std::uint64_t peak_resident_bytes();

/// The CPU seconds (user + system, all threads) this process has used so far (getrusage; 0 when
/// the system does not say).
double process_cpu_s();

/// The CPU seconds the calling thread has used so far (CLOCK_THREAD_CPUTIME_ID): what a piece of
/// work costs, whatever else shares the cores.
double thread_cpu_s();

/// The resident set size of this process now, in bytes (/proc/self/statm; 0 where it is absent).
std::uint64_t current_resident_bytes();

}  // namespace pvdf
