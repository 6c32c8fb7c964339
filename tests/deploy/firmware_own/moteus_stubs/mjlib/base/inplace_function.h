// encal test stub (not mjbots code): the only use here is a member that stores a callback.
#pragma once
#include <functional>

namespace mjlib {
namespace base {
template <typename Signature>
using inplace_function = std::function<Signature>;
}
}
