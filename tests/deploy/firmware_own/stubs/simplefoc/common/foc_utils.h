// encal test stub (written for encal, not SimpleFOC's file): what Sensor.cpp and CalibratedSensor.cpp use
// of the core library's common/foc_utils.h, for compiling them on the host.
#ifndef ENCAL_STUB_FOC_UTILS_H
#define ENCAL_STUB_FOC_UTILS_H
#include <math.h>
#include <stdint.h>
#include <string.h>
#include <cmath>
#include <cstdlib>
using std::abs;

#define _PI 3.14159265359f
#define _PI_2 1.57079632679f
#define _2PI 6.28318530718f
#define _3PI_2 4.71238898038f

// the core's normalisation into [0, 2 pi)
static inline float _normalizeAngle(float angle) {
    float a = fmod(angle, _2PI);
    return a >= 0 ? a : (a + _2PI);
}
#endif
