// encal test stub (not mjbots code): the motor fields motor_position.h reads (poles, the commutation offsets).
#pragma once
#include <array>
#include <cstdint>

namespace moteus {
struct BldcServoMotor {
  uint8_t poles = 0;
  std::array<float, 64> offset = {};
};
}
