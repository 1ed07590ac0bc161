#include "report.h"

#include "config.h"
#include "encoders.h"
#include "hal.h"
#include "serial.h"
#include "settings.h"
#include "stepper.h"
#include "system.h"

char* report_format_float(float value, uint8_t decimals, char* out) {
    uint32_t scale = 1;
    for (uint8_t i = 0; i < decimals; ++i) scale *= 10;
    bool negative = value < 0.0f;
    float magnitude = negative ? -value : value;
    uint32_t scaled = (uint32_t)(magnitude * (float)scale + 0.5f);
    if (scaled == 0) negative = false;  // no "-0.000"
    char digits[12];
    uint8_t n = 0;
    do {
        digits[n++] = (char)('0' + scaled % 10);
        scaled /= 10;
    } while (scaled > 0 || n <= decimals);
    char* p = out;
    if (negative) *p++ = '-';
    while (n > 0) {
        *p++ = digits[--n];
        if (n == decimals && decimals > 0) *p++ = '.';
    }
    *p = '\0';
    return out;
}

void report_float(float value, uint8_t decimals) {
    char text[16];
    serial_print(report_format_float(value, decimals, text));
}

void report_uint(uint32_t value) {
    char digits[11];
    uint8_t n = 0;
    do {
        digits[n++] = (char)('0' + value % 10);
        value /= 10;
    } while (value > 0);
    while (n > 0) serial_write((uint8_t)digits[--n]);
}

void report_ok() { serial_print_flash(FLASH_TEXT("ok\r\n")); }

void report_error(uint8_t code) {
    serial_print_flash(FLASH_TEXT("error:"));
    report_uint(code);
    serial_print_flash(FLASH_TEXT("\r\n"));
}

void report_alarm(uint8_t code) {
    serial_print_flash(FLASH_TEXT("ALARM:"));
    report_uint(code);
    serial_print_flash(FLASH_TEXT("\r\n"));
}

void report_banner() { serial_print_flash(FLASH_TEXT("\r\n" STAGE_BANNER "\r\n")); }

void report_message(const char* text) {
    serial_print_flash(FLASH_TEXT("[MSG:"));
    serial_print_flash(text);
    serial_print_flash(FLASH_TEXT("]\r\n"));
}

// grbl 1.1's help line, listing only the commands this board answers.
void report_help() { serial_print_flash(FLASH_TEXT("[HLP:$$ $I $x=val $X $H ~ ! ? ctrl-x]\r\n")); }

void report_build_info() {
    serial_print_flash(FLASH_TEXT("[VER:1.1h." STAGE_FIRMWARE_VERSION ":" STAGE_FIRMWARE_NAME "]\r\n"));
    serial_print_flash(FLASH_TEXT("[OPT:,"));
    report_uint(PLANNER_BLOCKS);
    serial_print_flash(FLASH_TEXT(","));
    report_uint(RX_BUFFER_SIZE);
    serial_print_flash(FLASH_TEXT("]\r\n[PROTO:" STAGE_PROTOCOL "]\r\n"));
}

void report_settings() {
    for (uint8_t i = 0; i < settings_count(); ++i) {
        uint16_t number = settings_number(i);
        serial_write('$');
        report_uint(number);
        serial_write('=');
        report_float(settings_get(number), settings_is_integer(number) ? 0 : 3);
        serial_print_flash(FLASH_TEXT("\r\n"));
    }
}

// x,y with three decimals (mm).
static void report_xy(float x, float y) {
    report_float(x, 3);
    serial_write(',');
    report_float(y, 3);
}

static void report_pins() {
    bool x = hal_limit_pressed(AXIS_X), y = hal_limit_pressed(AXIS_Y);
    if (!x && !y) return;
    serial_print_flash(FLASH_TEXT("|Pn:"));
    if (x) serial_write('X');
    if (y) serial_write('Y');
}

void report_status() {
    float position[AXIS_COUNT];
    system_position_mm(position);
    serial_write('<');
    serial_print(system_state_name());
    serial_print_flash(FLASH_TEXT("|MPos:"));
    report_xy(position[AXIS_X], position[AXIS_Y]);
    serial_print_flash(FLASH_TEXT(",0.000|FS:"));
    report_uint(stepper_speed_mm_min());
    serial_print_flash(FLASH_TEXT(",0"));
    if (settings.encoder_present && encoders_valid()) {
        serial_print_flash(FLASH_TEXT("|Enc:"));
        report_xy(encoders_position_mm(AXIS_X), encoders_position_mm(AXIS_Y));
    }
    report_pins();
    serial_print_flash(FLASH_TEXT(">\r\n"));
}
