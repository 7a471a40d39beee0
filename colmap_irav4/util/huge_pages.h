#pragma once

#include <cstddef>
#include <vector>

namespace colmap_irav4 {

// Asks the kernel to back the whole 2 MiB pages inside [data, data + bytes)
// with transparent huge pages (Linux; a no-op elsewhere, or where the
// kernel's THP mode is "never"). Worth it for a large array updated at
// scattered places, where each access of 4 KiB pages also misses the TLB.
// Takes effect on pages not yet touched. Returns the bytes advised.
size_t AdviseHugePages(void* data, size_t bytes);

// *values = n copies of `value`, its storage advised (AdviseHugePages)
// before it is first written.
template <typename T>
void AssignWithHugePages(size_t n, const T& value, std::vector<T>* values) {
  *values = {};
  values->reserve(n);
  AdviseHugePages(values->data(), n * sizeof(T));
  values->assign(n, value);
}

}  // namespace colmap_irav4
