#include "colmap_irav4/util/huge_pages.h"

#include <cstdint>

#if defined(__linux__)
#include <sys/mman.h>
#endif

namespace colmap_irav4 {

size_t AdviseHugePages(void* data, size_t bytes) {
#if defined(__linux__) && defined(MADV_HUGEPAGE)
  constexpr uintptr_t kHugePage = uintptr_t{2} << 20;
  const uintptr_t address = reinterpret_cast<uintptr_t>(data);
  const uintptr_t begin = (address + kHugePage - 1) & ~(kHugePage - 1);
  const uintptr_t end = (address + bytes) & ~(kHugePage - 1);
  if (data == nullptr || end <= begin) return 0;
  // Advice only: a kernel without THP refuses it, and nothing changes.
  if (madvise(reinterpret_cast<void*>(begin), end - begin, MADV_HUGEPAGE) !=
      0) {
    return 0;
  }
  return end - begin;
#else
  (void)data;
  (void)bytes;
  return 0;
#endif
}

}  // namespace colmap_irav4
