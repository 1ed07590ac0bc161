#include "report.h"

#include "config.h"
#include "serial.h"
#include "settings.h"

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
