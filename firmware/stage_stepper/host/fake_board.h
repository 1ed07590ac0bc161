// A simulated stage for the host builds: clock, step timer, two belt axes with limit switches
// at their physical zero, AS5600 encoders on the motor shafts, EEPROM, and faults to inject.
// Used by the unit tests and by the conformance simulator.
#ifndef STAGE_FAKE_BOARD_H
#define STAGE_FAKE_BOARD_H

#include <stdint.h>

#include <string>

struct fake_axis {
    double start_mm = 50.0;        // carriage position at power-up, from its limit switch
    int64_t motor_steps = 0;       // steps the motor really made
    int64_t commanded_steps = 0;   // step pulses received
    double stall_beyond_mm = 1e9;  // fault: the motor stops turning past this position
    bool magnet_missing = false;   // fault: AS5600 status without MD
    bool encoder_silent = false;   // fault: no I2C answer
    uint16_t angle_offset = 1234;  // magnet's angle at position 0, counts
};

struct fake_board {
    uint64_t now_us = 0;
    bool timer_running = false;
    uint16_t timer_period_ticks = 0;
    uint64_t next_tick_ns = 0;     // when the step timer fires next, ns
    double steps_per_mm = 80.0;    // the mechanics (must match $100/$101 for a true stage)
    double mm_per_turn = 40.0;
    fake_axis axes[2];
    uint8_t eeprom[1024];
    std::string tx;                // everything the firmware printed
    fake_board();
};

extern fake_board board;

// Carriage position of an axis, mm from its limit switch.
double fake_position_mm(int axis);

// Advances simulated time by dt_us, firing the step timer on time and running the main loop
// every loop_us.
void fake_run(double dt_us, double loop_us = 100.0);

// Sends bytes as if received on the serial line.
void fake_receive(const std::string& bytes);

#endif
