// The memory a benchmark process holds, for bytes-per-asperity figures (mdr_interface_bench,
// mdr_million_asperities). Linux only (/proc/self, glibc's mallinfo2).
#pragma once

#include <malloc.h>

#include <fstream>
#include <string>

namespace mdr::bench {

// The resident size of the process now, in bytes.
inline long ResidentBytes() {
  std::ifstream statm("/proc/self/statm");
  long pages = 0, resident = 0;
  statm >> pages >> resident;
  return resident * 4096;
}

// The largest resident size of the process so far (VmHWM), in bytes.
inline long PeakResidentBytes() {
  std::ifstream status("/proc/self/status");
  std::string key;
  long kib = 0;
  while (status >> key) {
    if (key == "VmHWM:") {
      status >> kib;
      return kib * 1024;
    }
  }
  return 0;
}

// Bytes the allocator has handed out and not taken back (small blocks and mapped ones): unlike
// the resident size, it does not depend on what earlier benchmarks freed into the heap.
inline long HeapInUse() {
  const struct mallinfo2 m = mallinfo2();
  return static_cast<long>(m.uordblks + m.hblkhd);
}

}  // namespace mdr::bench
