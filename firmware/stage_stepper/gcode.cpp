#include "gcode.h"

#include <math.h>

#include "settings.h"
#include "wc_codes.h"

enum : uint8_t {
    WORD_X = 0x01,
    WORD_Y = 0x02,
    WORD_F = 0x04,
    WORD_P = 0x08,
};

// The modal groups of the G words this stage knows (grbl 1.1 / RS274NGC numbering in comments).
enum : uint8_t {
    GROUP_NON_MODAL = 0x01,  // group 0: G4
    GROUP_MOTION = 0x02,     // group 1: G0, G1
    GROUP_PLANE = 0x04,      // group 2: G17
    GROUP_DISTANCE = 0x08,   // group 3: G90, G91
    GROUP_FEED_MODE = 0x10,  // group 5: G94
    GROUP_UNITS = 0x20,      // group 6: G21
};

struct gcode_words {
    uint8_t seen;          // WORD_* bits
    uint8_t groups;        // GROUP_* bits of the G words on the line
    uint8_t motion;        // 0 or 1, when GROUP_MOTION is set
    bool incremental;      // G91, when GROUP_DISTANCE is set
    float value[4];        // X, Y, F, P
};

void gcode_init(gcode_modal& modal) {
    modal.motion = 0;
    modal.incremental = false;
    modal.feed_mm_min = 0.0f;
}

bool gcode_read_number(const char** text, float* value) {
    const char* p = *text;
    bool negative = false;
    if (*p == '-' || *p == '+') negative = (*p++ == '-');
    float result = 0.0f, scale = 1.0f;
    bool digits = false, fraction = false;
    // Accumulate in integer steps of the decimal place so "0.1" parses as exactly as a float can.
    for (;; ++p) {
        if (*p >= '0' && *p <= '9') {
            digits = true;
            result = result * 10.0f + (float)(*p - '0');
            if (fraction) scale *= 10.0f;
        } else if (*p == '.' && !fraction) {
            fraction = true;
        } else {
            break;
        }
    }
    if (!digits) return false;
    *value = (negative ? -result : result) / scale;
    *text = p;
    return true;
}

// GROUP_* of an integer G code, 0 for the ones this stage does not know.
static uint8_t gcode_group(int code) {
    switch (code) {
        case 0:
        case 1:
            return GROUP_MOTION;
        case 4:
            return GROUP_NON_MODAL;
        case 17:  // XY plane: the only one
            return GROUP_PLANE;
        case 90:
        case 91:
            return GROUP_DISTANCE;
        case 94:  // feed per minute: the only feed mode
            return GROUP_FEED_MODE;
        case 21:  // millimetres: the only unit
            return GROUP_UNITS;
        default:
            return 0;
    }
}

static uint8_t gcode_g_word(float value, gcode_words& words) {
    if (value != floorf(value)) return STAGE_ERROR_UNSUPPORTED_COMMAND;  // G38.2 and the like
    int code = (int)value;
    uint8_t group = gcode_group(code);
    if (!group) return STAGE_ERROR_UNSUPPORTED_COMMAND;
    // grbl refuses a second motion command as a conflict over the axis words, before the group.
    if (group == GROUP_MOTION && (words.groups & GROUP_MOTION)) return STAGE_ERROR_AXIS_WORDS_CONFLICT;
    if (words.groups & group) return STAGE_ERROR_MODAL_GROUP_VIOLATION;
    words.groups |= group;
    if (group == GROUP_MOTION) words.motion = (uint8_t)code;
    if (group == GROUP_DISTANCE) words.incremental = code == 91;
    return 0;
}

static uint8_t gcode_value_word(char letter, float value, gcode_words& words) {
    static const char LETTERS[] = "XYFP";
    for (uint8_t i = 0; i < 4; ++i) {
        if (LETTERS[i] != letter) continue;
        if (words.seen & (1 << i)) return STAGE_ERROR_WORD_REPEATED;
        if (i >= 2 && value < 0.0f) return STAGE_ERROR_NEGATIVE_VALUE;
        words.seen |= (uint8_t)(1 << i);
        words.value[i] = value;
        return 0;
    }
    if (letter == 'N') return 0;  // line numbers are accepted and ignored
    return STAGE_ERROR_UNSUPPORTED_COMMAND;
}

static uint8_t gcode_read_words(const char* line, gcode_words& words) {
    words.seen = words.groups = words.motion = 0;
    words.incremental = false;
    while (*line) {
        char letter = *line++;
        if (letter < 'A' || letter > 'Z') return STAGE_ERROR_EXPECTED_COMMAND_LETTER;
        float value = 0.0f;
        if (!gcode_read_number(&line, &value)) return STAGE_ERROR_BAD_NUMBER_FORMAT;
        uint8_t error = letter == 'G' ? gcode_g_word(value, words) : gcode_value_word(letter, value, words);
        if (error) return error;
    }
    return 0;
}

static uint8_t gcode_check_travel(const float target_mm[AXIS_COUNT]) {
    for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) {
        if (!isfinite(target_mm[axis]) || fabsf(target_mm[axis]) > 1.0e6f) return STAGE_ERROR_INVALID_TARGET;
        if (!settings.soft_limits) continue;
        // A micrometre of slack so that "X200" on a 200 mm axis is not refused by rounding.
        if (target_mm[axis] < -0.001f || target_mm[axis] > settings.travel_mm[axis] + 0.001f) {
            return STAGE_ERROR_TRAVEL_EXCEEDED;
        }
    }
    return 0;
}

static uint8_t gcode_motion(const gcode_words& words, gcode_modal& next, const float position_mm[AXIS_COUNT],
                            gcode_action& action) {
    action.kind |= GCODE_MOVE;
    for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) {
        action.target_mm[axis] = position_mm[axis];
        if (!(words.seen & (1 << axis))) continue;
        action.target_mm[axis] = next.incremental ? position_mm[axis] + words.value[axis] : words.value[axis];
    }
    action.feed_mm_min = next.motion == 1 ? next.feed_mm_min : 1.0e9f;  // G0: as fast as the axes go
    return gcode_check_travel(action.target_mm);
}

// The block's new modal state: what its G and F words change.
static gcode_modal gcode_next_modal(const gcode_words& words, const gcode_modal& modal) {
    gcode_modal next = modal;
    if (words.groups & GROUP_MOTION) next.motion = words.motion;
    if (words.groups & GROUP_DISTANCE) next.incremental = words.incremental;
    if (words.seen & WORD_F) next.feed_mm_min = words.value[2];
    return next;
}

uint8_t gcode_parse(const char* line, gcode_modal& modal, const float position_mm[AXIS_COUNT], gcode_action& action) {
    gcode_words words;
    uint8_t error = gcode_read_words(line, words);
    if (error) return error;
    gcode_modal next = gcode_next_modal(words, modal);
    action.kind = GCODE_NOTHING;
    if (words.groups & GROUP_NON_MODAL) {
        if (!(words.seen & WORD_P)) return STAGE_ERROR_VALUE_WORD_MISSING;
        action.kind = GCODE_DWELL;
        action.dwell_s = words.value[3];
    }
    bool axes = (words.seen & (WORD_X | WORD_Y)) != 0;
    // A motion command, or axis words in the modal motion mode; as in grbl, G0 and G1 without
    // axis words only set the mode, but G1 still needs a feed rate.
    if (axes || (words.groups & GROUP_MOTION)) {
        if (next.motion == 1 && next.feed_mm_min <= 0.0f) return STAGE_ERROR_UNDEFINED_FEED_RATE;
        if (axes) error = gcode_motion(words, next, position_mm, action);
        if (error) return error;
    }
    modal = next;
    return 0;
}
