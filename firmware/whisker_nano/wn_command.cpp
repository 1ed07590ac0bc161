#include "wn_command.h"

#include <stdio.h>
#include <string.h>

#include "wc_codes.h"
#include "wn_frame.h"
#include "wn_hal.h"

void command_reader_init(command_reader& reader) {
    reader.length = 0;
    reader.overflowed = false;
}

static void command_send_text(const char* text) {
    uint8_t frame[FRAME_TEXT_MAX + FRAME_OVERHEAD];
    // Answers are rare and short: waiting for buffer room here is acceptable, losing them is not.
    hal_tx_write(frame, frame_encode_text(text, frame));
}

static void command_error(char* answer, uint8_t code) {
    snprintf(answer, FRAME_TEXT_MAX + 1, "ERR:%u", (unsigned)code);
}

void command_receive(command_reader& reader, char c, sampler_state& sampler, uint32_t now_us) {
    char answer[FRAME_TEXT_MAX + 1];
    if (c == '\r') return;
    if (c != '\n') {
        if (reader.length < COMMAND_LINE_MAX) {
            reader.line[reader.length++] = c;
        } else {
            reader.overflowed = true;
        }
        return;
    }
    reader.line[reader.length] = '\0';
    bool answered = true;
    if (reader.overflowed) {
        command_error(answer, SENSOR_ERROR_LINE_TOO_LONG);
    } else {
        answered = command_execute(reader.line, sampler, now_us, answer);
    }
    command_reader_init(reader);
    if (answered) command_send_text(answer);
}

// Parses a decimal integer in [low, high] that makes up the whole of text.
static bool command_parse_uint(const char* text, uint16_t low, uint16_t high, uint16_t* value) {
    if (*text == '\0') return false;
    uint32_t v = 0;
    for (; *text; ++text) {
        if (*text < '0' || *text > '9') return false;
        v = v * 10 + (uint32_t)(*text - '0');
        if (v > high) return false;
    }
    if (v < low) return false;
    *value = (uint16_t)v;
    return true;
}

static bool command_is(const char* line, const char* name, const char** argument) {
    size_t n = strlen(name);
    if (strncmp(line, name, n) != 0) return false;
    if (line[n] != '\0' && line[n] != ' ') return false;
    const char* p = line + n;
    while (*p == ' ') ++p;  // "GAIN  3" is "GAIN 3"
    *argument = p;
    return true;
}

// Upper case, without leading and trailing blanks: commands typed in a terminal work too.
static void command_normalize(const char* line, char* out) {
    while (*line == ' ' || *line == '\t') ++line;
    size_t n = 0;
    for (; line[n] && n < COMMAND_LINE_MAX; ++n) {
        char c = line[n];
        out[n] = (c >= 'a' && c <= 'z') ? (char)(c - 'a' + 'A') : c;
    }
    while (n > 0 && (out[n - 1] == ' ' || out[n - 1] == '\t')) --n;
    out[n] = '\0';
}

// Settings commands: validate, refuse while streaming, check that the conversion still fits.
static uint8_t command_setting(const char* name, const char* argument, sampler_state& s) {
    uint16_t value = 0;
    if (strcmp(name, "RATE") == 0) {
        if (!command_parse_uint(argument, SAMPLER_RATE_MIN_HZ, SAMPLER_RATE_MAX_HZ, &value)) return SENSOR_ERROR_BAD_VALUE;
        if (s.streaming) return SENSOR_ERROR_BUSY_STREAMING;
        if (!sampler_fits(value, s.mlx.osr, s.mlx.filt)) return SENSOR_ERROR_RATE_TOO_HIGH;
        s.rate_hz = value;
        return 0;
    }
    uint16_t high = strcmp(name, "GAIN") == 0 ? MLX_GAIN_MAX : strcmp(name, "FILT") == 0 ? MLX_FILT_MAX : MLX_RES_MAX;
    if (!command_parse_uint(argument, 0, high, &value)) return SENSOR_ERROR_BAD_VALUE;
    if (s.streaming) return SENSOR_ERROR_BUSY_STREAMING;
    mlx_settings next = s.mlx;
    if (strcmp(name, "GAIN") == 0) next.gain = (uint8_t)value;
    if (strcmp(name, "RES") == 0) next.res = (uint8_t)value;
    if (strcmp(name, "OSR") == 0) next.osr = (uint8_t)value;
    if (strcmp(name, "FILT") == 0) next.filt = (uint8_t)value;
    if (!sampler_fits(s.rate_hz, next.osr, next.filt)) return SENSOR_ERROR_RATE_TOO_HIGH;
    s.mlx = next;
    return 0;
}

static const char* const COMMAND_SETTINGS[] = {"RATE", "GAIN", "RES", "OSR", "FILT"};

bool command_execute(const char* raw_line, sampler_state& s, uint32_t now_us, char* answer) {
    const char* argument = 0;
    char line[COMMAND_LINE_MAX + 1];
    command_normalize(raw_line, line);
    if (line[0] == '\0') return false;
    strcpy(answer, "OK");
    if (strcmp(line, "ID") == 0) {
        strcpy(answer, "OK whisker_nano fw=" WN_FIRMWARE_VERSION " proto=" WN_PROTOCOL_VERSION);
    } else if (strcmp(line, "CFG?") == 0) {
        snprintf(answer, FRAME_TEXT_MAX + 1, "OK rate=%u gain=%u res=%u osr=%u filt=%u", (unsigned)s.rate_hz,
                 (unsigned)s.mlx.gain, (unsigned)s.mlx.res, (unsigned)s.mlx.osr, (unsigned)s.mlx.filt);
    } else if (strcmp(line, "START") == 0) {
        if (!s.streaming) sampler_start(s, now_us);
    } else if (strcmp(line, "STOP") == 0) {
        sampler_stop(s);
    } else {
        for (uint8_t i = 0; i < sizeof(COMMAND_SETTINGS) / sizeof(COMMAND_SETTINGS[0]); ++i) {
            if (!command_is(line, COMMAND_SETTINGS[i], &argument)) continue;
            uint8_t error = command_setting(COMMAND_SETTINGS[i], argument, s);
            if (error) command_error(answer, error);
            return true;
        }
        command_error(answer, SENSOR_ERROR_UNKNOWN_COMMAND);
    }
    return true;
}
