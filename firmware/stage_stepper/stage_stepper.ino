// stage_stepper: the two-axis calibration stage of whiskercal. grbl 1.1-style protocol
// (docs/protocol.md, "Stage"), trapezoidal step generation from Timer1, AS5600 encoders through
// a TCA9548A, limit-switch homing, settings in EEPROM. Wiring and settings: docs/firmware.md.
// Build with `make firmware` (it adds the include paths of the shared code table).
#include <Arduino.h>
#include <Wire.h>

#include "stage.h"

void setup() { stage_init(); }

void loop() { stage_loop(); }
