#pragma once
#include <cstdint>

namespace bench {

// Resident memory from /proc/self/status (Linux), in bytes.
struct Rss {
  int64_t current = 0;  // VmRSS
  int64_t peak = 0;     // VmHWM: the most resident since the process started or the peak was last reset
};

Rss readRss();

// The highest VmHWM this process reached, across the resets of the probes below.
int64_t processPeakRss();

// What a phase of the benchmark adds to the resident memory: create the probe, do the work, and call
// growth() while the work's objects are still alive. The probe first gives freed heap memory back
// (malloc_trim) and resets the kernel's peak (/proc/self/clear_refs), so the peak is this phase's.
class MemoryProbe {
 public:
  MemoryProbe();
  struct Growth {
    int64_t retained = 0;  // resident now - resident at the start
    int64_t peak = 0;      // highest resident during the phase - resident at the start
  };
  Growth growth() const;

 private:
  int64_t m_start;
};

}  // namespace bench
