// stage_stepper core on the host: protocol bytes on stdin and stdout, a simulated stage behind
// it, a clock that runs --speed times real time. The conformance tests drive it over a pipe.
//   stage_stepper_sim [--speed F] [--start X,Y] [--stall-x MM] [--no-magnet-y] [--silent-x]
// --start: carriage positions from the limit switches at power-up, mm; --stall-x: the X motor
// stops turning beyond this position; --no-magnet-y / --silent-x: encoder faults.
#include <poll.h>
#include <time.h>
#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "../serial.h"
#include "../stage.h"
#include "fake_board.h"
#include "host_pipe.h"

// Feeds what stdin holds to the receive path; false at end of input.
static bool pump_input() {
    pollfd pfd = {STDIN_FILENO, POLLIN, 0};
    while (poll(&pfd, 1, 0) > 0) {
        char buffer[256];
        ssize_t n = read(STDIN_FILENO, buffer, sizeof buffer);
        if (n <= 0) return false;
        for (ssize_t i = 0; i < n; ++i) serial_receive_byte((uint8_t)buffer[i]);
    }
    return true;
}

static bool parse_options(int argc, char** argv, double* speed) {
    for (int i = 1; i < argc; ++i) {
        bool more = i + 1 < argc;
        if (!std::strcmp(argv[i], "--speed") && more) *speed = std::atof(argv[++i]);
        else if (!std::strcmp(argv[i], "--start") && more)
            std::sscanf(argv[++i], "%lf,%lf", &board.axes[0].start_mm, &board.axes[1].start_mm);
        else if (!std::strcmp(argv[i], "--stall-x") && more) board.axes[0].stall_beyond_mm = std::atof(argv[++i]);
        else if (!std::strcmp(argv[i], "--no-magnet-y")) board.axes[1].magnet_missing = true;
        else if (!std::strcmp(argv[i], "--silent-x")) board.axes[0].encoder_silent = true;
        else return false;
    }
    return true;
}

int main(int argc, char** argv) {
    double speed = 1.0;
    if (!parse_options(argc, argv, &speed)) {
        std::fprintf(stderr, "usage: %s [--speed F] [--start X,Y] [--stall-x MM] [--no-magnet-y] [--silent-x]\n", argv[0]);
        return 2;
    }
    stage_init();
    host_flush_to_stdout(board.tx);
    const double start = host_real_seconds();
    double simulated_us = 0.0;
    while (pump_input()) {
        double target_us = (host_real_seconds() - start) * speed * 1e6;
        if (target_us > simulated_us) {
            fake_run(target_us - simulated_us);
            simulated_us = target_us;
        } else {
            fake_run(0.0);  // still answer what just arrived
        }
        host_flush_to_stdout(board.tx);
        usleep(100);
    }
    return 0;
}
