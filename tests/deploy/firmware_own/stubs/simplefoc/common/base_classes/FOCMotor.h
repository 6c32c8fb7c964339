// encal test stub: the members of FOCMotor that CalibratedSensor::calibrate() names, so the file compiles.
// The harness never calls calibrate(); it only loads a table and reads getSensorAngle() through update().
#ifndef ENCAL_STUB_FOCMOTOR_H
#define ENCAL_STUB_FOCMOTOR_H
#include "common/base_classes/Sensor.h"
#include "common/foc_utils.h"
#include "common/time_utils.h"
#include <stddef.h>

class Print {
public:
    template <class T> size_t print(T, int = 2) { return 0; }
    template <class T> size_t println(T, int = 2) { return 0; }
    size_t println() { return 0; }
};
extern Print Serial;

class CurrentSense {};

class FOCMotor {
public:
    int pole_pairs = 7;
    float zero_electric_angle = 0.0f;
    Direction sensor_direction = Direction::CW;
    Print *monitor_port = nullptr;
    CurrentSense *current_sense = nullptr;
    void linkSensor(Sensor *) {}
    void linkCurrentSense(CurrentSense *) {}
    int initFOC() { return 0; }
    virtual void setPhaseVoltage(float, float, float) {}
    virtual ~FOCMotor() {}
};
#endif
