// encal test stub (not mjbots code): configuration is set directly through MotorPosition::config().
#pragma once

namespace mjlib {
namespace micro {
class PersistentConfig {
 public:
  template <typename Structure, typename Callback>
  void Register(const char*, Structure*, Callback) {}
};
}
}
