// The stage's serial protocol: realtime requests first, then received bytes assembled into
// normalized lines (upper case, no spaces or comments), dispatched to '$' commands or G-code
// and answered with ok / error:N.
#ifndef STAGE_PROTOCOL_H
#define STAGE_PROTOCOL_H

#include <stdint.h>

void protocol_init();

// Acts on ? ! ~ and soft reset.
void protocol_realtime();

// Reads received bytes and executes complete lines while the planner has room.
void protocol_lines();

#endif
