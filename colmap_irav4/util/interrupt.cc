#include "colmap_irav4/util/interrupt.h"

#include <atomic>

namespace colmap_irav4 {
namespace {

std::atomic<bool> g_interrupt_requested(false);

}  // namespace

void RequestInterrupt() { g_interrupt_requested = true; }

void ClearInterrupt() { g_interrupt_requested = false; }

bool InterruptRequested() {
  return g_interrupt_requested.load(std::memory_order_relaxed);
}

void ThrowIfInterrupted() {
  if (InterruptRequested()) throw Interrupted();
}

}  // namespace colmap_irav4
