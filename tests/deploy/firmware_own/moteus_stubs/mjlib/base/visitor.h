// encal test stub (not mjbots code): serialization is never used by the harness.
#pragma once
#include <algorithm>
#include <cstdint>
#include <cstdlib>
#include <limits>
#include <utility>

#define MJ_NVP(x) (x)
#define MJ_ASSERT(x) do { if (!(x)) { std::abort(); } } while (0)

namespace mjlib {
namespace base {
template <typename T>
struct IsEnum {
  static constexpr bool value = false;
};
}
}
