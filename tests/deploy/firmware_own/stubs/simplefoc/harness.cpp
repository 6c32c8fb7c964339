// encal test harness (written for encal): loads a table into the library's own CalibratedSensor and reads
// the calibrated angle of every code through the core's own Sensor::update (which drops negative angles).
#include "CalibratedSensor.h"

Print Serial;

// A magnetic sensor: the angle of a code as SimpleFOC's MagneticSensorSPI computes it.
class CodeSensor : public Sensor {
public:
    uint32_t code = 0;
    uint32_t cpr = 1;
    float getSensorAngle() override { return (code / (float)cpr) * _2PI; }
};

#ifdef ENCAL_DRIVERS_1_0_8
// 1.0.8 takes no table: its calibrationLut is a protected member filled by calibrate(); a subclass fills it.
class LoadedSensor : public CalibratedSensor {
public:
    LoadedSensor(Sensor &wrapped, const float *lut) : CalibratedSensor(wrapped) {
        for (int i = 0; i < n_lut; i++) calibrationLut[i] = lut[i];
    }
    int nodes() const { return n_lut; }
};
#endif

extern "C" int encal_calibrated_angles(const float *lut, int n, int bits, float *out) {
    CodeSensor *raw = new CodeSensor();  // never freed: 1.0.8's destructor deletes with the wrong operator
    raw->cpr = 1u << bits;
#ifdef ENCAL_DRIVERS_1_0_8
    LoadedSensor *calibrated = new LoadedSensor(*raw, lut);
    if (calibrated->nodes() != n) return -1;
#else
    float *table = new float[n];
    for (int i = 0; i < n; i++) table[i] = lut[i];
    CalibratedSensor *calibrated = new CalibratedSensor(*raw, n, table);
#endif
    // turning forward: the last code first, then every code in order
    raw->code = raw->cpr - 1;
    calibrated->update();
    for (uint32_t code = 0; code < raw->cpr; code++) {
        raw->code = code;
        calibrated->update();
        out[code] = calibrated->getMechanicalAngle();
    }
    return 0;
}
