// encal test driver (not mjbots code): runs moteus's own MotorPosition (fw/motor_position.h, included
// unmodified from ../shared/firmware/moteus) over every code of one SPI encoder.
//
// stdin:  bits sign offset scale table[0] ... table[N-1]   (offset and scale as text, parsed with strtof
//         as the firmware's configuration parser does for a float field)
// stdout: cpr uint32 offset_value values, then cpr float32 compensated_value values (native endianness)
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include "fw/motor_position.h"

int main() {
  int bits = 0;
  int sign = 1;
  char offset_text[64] = {};
  char scale_text[64] = {};
  if (std::scanf("%d %d %63s %63s", &bits, &sign, offset_text, scale_text) != 4) { return 2; }
  const uint32_t cpr = 1u << bits;

  mjlib::micro::PersistentConfig persistent_config;
  mjlib::micro::TelemetryManager telemetry_manager;
  moteus::aux::AuxStatus aux1_status, aux2_status;
  moteus::aux::AuxConfig aux1_config, aux2_config;
  // The modes whose cpr the firmware forces to the encoder's: AS5047 (14 bits), MA732 (16 bits).
  aux1_config.spi.mode = bits == 14 ? moteus::aux::Spi::Config::kOnboardAs5047 : moteus::aux::Spi::Config::kMa732;

  moteus::MotorPosition position(&persistent_config, &telemetry_manager, &aux1_status, &aux2_status,
                                 &aux1_config, &aux2_config);
  position.motor()->poles = 14;
  auto& source = position.config()->sources[0];
  source.aux_number = 1;
  source.type = moteus::MotorPosition::SourceConfig::kSpi;
  source.cpr = cpr;
  source.offset = std::strtof(offset_text, nullptr);
  source.sign = static_cast<int8_t>(sign);
  source.compensation_scale = std::strtof(scale_text, nullptr);
  for (auto& value : source.compensation_table) {
    int entry = 0;
    if (std::scanf("%d", &entry) != 1) { return 3; }
    value = static_cast<int8_t>(entry);
  }
  position.ApplyConfig();
  if (position.status().error != moteus::MotorPosition::Status::kNone) { return 4; }
  if (position.config()->sources[0].cpr != cpr) { return 5; }

  std::vector<uint32_t> offset_values(cpr);
  std::vector<float> compensated(cpr);
  aux1_status.spi.active = true;
  for (uint32_t raw = 0; raw < cpr; raw++) {
    aux1_status.spi.value = raw;
    aux1_status.spi.nonce++;
    position.ISR_Update();
    offset_values[raw] = position.status().sources[0].offset_value;
    compensated[raw] = position.status().sources[0].compensated_value;
  }
  std::fwrite(offset_values.data(), sizeof(uint32_t), cpr, stdout);
  std::fwrite(compensated.data(), sizeof(float), cpr, stdout);
  return 0;
}
