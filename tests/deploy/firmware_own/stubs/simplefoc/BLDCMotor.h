// encal test stub: BLDCMotor as far as CalibratedSensor (1.0.8) names it.
#ifndef ENCAL_STUB_BLDCMOTOR_H
#define ENCAL_STUB_BLDCMOTOR_H
#include "common/base_classes/FOCMotor.h"
class BLDCMotor : public FOCMotor {};
#endif
