// Command lines of the sensor protocol (docs/protocol.md, "Commands"): assembles bytes into
// lines and answers each command with one text frame, "OK ..." or "ERR:N".
#ifndef WN_COMMAND_H
#define WN_COMMAND_H

#include <stdint.h>

#include "wn_sampler.h"

#define WN_FIRMWARE_VERSION "0.1.0"
#define WN_PROTOCOL_VERSION "1"

enum : uint8_t { COMMAND_LINE_MAX = 32 };

struct command_reader {
    char line[COMMAND_LINE_MAX + 1];
    uint8_t length;
    bool overflowed;  // the current line is too long: answer ERR:6 at its end
};

void command_reader_init(command_reader& reader);

// Feeds one received byte; at the end of a line executes it and sends the answer frame.
void command_receive(command_reader& reader, char c, sampler_state& sampler, uint32_t now_us);

// Executes one command line (without its newline) and writes the answer text to answer
// (room for FRAME_TEXT_MAX + 1 chars). Returns false for an empty line, which gets no answer.
bool command_execute(const char* line, sampler_state& sampler, uint32_t now_us, char* answer);

#endif
