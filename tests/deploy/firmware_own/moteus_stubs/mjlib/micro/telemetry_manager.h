// encal test stub (not mjbots code): no telemetry.
#pragma once

namespace mjlib {
namespace micro {
class TelemetryManager {
 public:
  template <typename Structure>
  void Register(const char*, Structure*) {}
};
}
}
