// Everything stage_stepper prints: ok, error:N, ALARM:N, the banner, [MSG:], the status report,
// the '$' help, $I and $$.
#ifndef STAGE_REPORT_H
#define STAGE_REPORT_H

#include <stdint.h>

void report_ok();
void report_error(uint8_t code);
void report_alarm(uint8_t code);
void report_banner();
void report_message(const char* flash_text);  // [MSG:text], text given with FLASH_TEXT()
void report_help();        // [HLP:...]: the '$' commands and realtime bytes this board knows
void report_build_info();
void report_settings();

// <State|MPos:x,y,0.000|FS:feed,0|Enc:x,y|Pn:XY>; Enc only with encoders ($200=1), Pn only
// while a limit switch is pressed.
void report_status();

// Fixed-point decimal of value with the given number of decimals (no printf float on AVR).
void report_float(float value, uint8_t decimals);
void report_uint(uint32_t value);

// Formats value into out (room for 16 chars); returns out. Shared with the host tests.
char* report_format_float(float value, uint8_t decimals, char* out);

#endif
