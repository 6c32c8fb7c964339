// encal test stub (not mjbots code): the two names motor_position.h uses.
#pragma once
#include <cmath>

namespace moteus {
constexpr float k2Pi = 6.28318530718f;

inline float WrapZeroToTwoPi(float value) {
  const float result = std::fmod(value, k2Pi);
  return result < 0.0f ? result + k2Pi : result;
}
}
