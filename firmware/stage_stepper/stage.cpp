#include "stage.h"

#include "encoders.h"
#include "hal.h"
#include "planner.h"
#include "protocol.h"
#include "serial.h"
#include "settings.h"
#include "stepper.h"
#include "system.h"

void stage_init() {
    serial_init();
    hal_init();
    bool settings_valid = settings_load();
    planner_init();
    stepper_init();
    encoders_init();
    system_init();
    protocol_init();
    system_start(settings_valid);
}

void stage_loop() {
    protocol_realtime();
    protocol_lines();
    system_update(hal_micros());
    stepper_prep();
}
