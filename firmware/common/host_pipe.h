// Host-side plumbing shared by both boards' simulators (host/sim_main.cpp): the real clock and
// writing what the firmware sent to stdout. Host builds only; nothing here goes on the AVR.
#pragma once

#include <time.h>
#include <unistd.h>

#include <cstdlib>

// Seconds on the monotonic clock.
inline double host_real_seconds() {
    timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return (double)ts.tv_sec + 1e-9 * (double)ts.tv_nsec;
}

// Writes all of `tx` (a std::string or std::vector of bytes) to stdout and empties it; exits
// quietly when the reader went away.
template <typename Buffer>
inline void host_flush_to_stdout(Buffer& tx) {
    size_t sent = 0;
    while (sent < tx.size()) {
        ssize_t n = write(STDOUT_FILENO, tx.data() + sent, tx.size() - sent);
        if (n <= 0) std::exit(0);
        sent += (size_t)n;
    }
    tx.clear();
}
