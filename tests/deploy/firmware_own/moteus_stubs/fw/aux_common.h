// encal test stub (not mjbots code): the auxiliary-port status and configuration fields motor_position.h
// reads. The harness drives one SPI source; the other sources are declared so the header compiles.
#pragma once
#include <array>
#include <cstdint>

namespace moteus {
namespace aux {

enum class AuxError { kNone, kFault };

struct Spi {
  struct Config {
    enum Mode { kOnboardAs5047, kDisabled, kAs5047, kIcPz, kMa732, kOrbis, kMa600, kOnboardMa600 };
  };
};

struct UartEncoder {
  struct Config {
    enum Mode { kDisabled, kAksim2, kCuiAmt21 };
  };
};

struct SourceData {
  bool active = false;
  uint32_t value = 0;
  uint8_t nonce = 0;
};

struct HallData {
  bool active = false;
  uint8_t bits = 0;
  uint8_t count = 0;
  uint8_t nonce = 0;
};

struct QuadratureData {
  bool active = false;
  uint32_t value = 0;
};

struct IndexData {
  bool active = false;
  bool value = false;
};

struct I2CStatus {
  std::array<SourceData, 3> devices = {};
};

struct AuxStatus {
  uint8_t epoch = 0;
  AuxError error = AuxError::kNone;
  SourceData spi;
  SourceData uart;
  SourceData bissc;
  SourceData sine_cosine;
  I2CStatus i2c;
  HallData hall;
  QuadratureData quadrature;
  IndexData index;
};

struct PollRate {
  uint32_t poll_rate_us = 1000;
};

struct AuxConfig {
  struct {
    Spi::Config::Mode mode = Spi::Config::kOnboardAs5047;
  } spi;
  struct {
    UartEncoder::Config::Mode mode = UartEncoder::Config::kDisabled;
    uint32_t poll_rate_us = 1000;
  } uart;
  PollRate bissc;
  struct {
    std::array<PollRate, 3> devices = {};
  } i2c;
};

}
}
