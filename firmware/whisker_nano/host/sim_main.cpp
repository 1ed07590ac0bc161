// whisker_nano core on the host: commands on stdin, frames on stdout, a simulated MLX90393 and
// a clock that runs --speed times real time. The conformance tests drive it over a pipe.
//   wn_sim [--speed F] [--no-sensor] [--field X,Y,Z]   (field in µT)
#include <poll.h>
#include <time.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>

#include "../wn_command.h"
#include "../wn_sampler.h"
#include "fake_board.h"
#include "host_pipe.h"

// Reads what stdin holds without waiting; returns false at end of input.
static bool pump_input(command_reader& reader, sampler_state& sampler) {
    pollfd pfd = {STDIN_FILENO, POLLIN, 0};
    while (poll(&pfd, 1, 0) > 0) {
        char buffer[256];
        ssize_t n = read(STDIN_FILENO, buffer, sizeof buffer);
        if (n <= 0) return false;
        for (ssize_t i = 0; i < n; ++i) command_receive(reader, buffer[i], sampler, board.now_us);
    }
    return true;
}

int main(int argc, char** argv) {
    double speed = 1.0;
    for (int i = 1; i < argc; ++i) {
        if (!std::strcmp(argv[i], "--speed") && i + 1 < argc) speed = std::atof(argv[++i]);
        else if (!std::strcmp(argv[i], "--no-sensor")) board.mlx_present = false;
        else if (!std::strcmp(argv[i], "--field") && i + 1 < argc)
            std::sscanf(argv[++i], "%lf,%lf,%lf", &board.field_uT[0], &board.field_uT[1], &board.field_uT[2]);
        else { std::fprintf(stderr, "usage: %s [--speed F] [--no-sensor] [--field X,Y,Z]\n", argv[0]); return 2; }
    }
    sampler_state sampler;
    command_reader reader;
    sampler_init(sampler);
    command_reader_init(reader);
    const double start = host_real_seconds();
    const double static_y = board.field_uT[1];
    uint64_t simulated_us = 0;
    while (pump_input(reader, sampler)) {
        uint64_t target_us = (uint64_t)((host_real_seconds() - start) * speed * 1e6);
        // The board's loop polls every ~20 µs: step the simulated clock as finely.
        for (; simulated_us < target_us; simulated_us += 20) {
            board.now_us = (uint32_t)simulated_us;
            // A slow 1 Hz wobble on Y so that successive samples differ.
            board.field_uT[1] = static_y + 50.0 * std::sin(2.0 * M_PI * simulated_us * 1e-6);
            sampler_poll(sampler, board.now_us);
        }
        host_flush_to_stdout(board.tx);
        usleep(100);
    }
    return 0;
}
