// Protocol codes shared with the host: generated from whiskercal/protocol/protocol_codes.def.
// Build with -I<repo>/whiskercal/protocol so that the one table is compiled in, never copied.
// Each row X(KIND, NUMBER, NAME, "text") becomes the constant KIND_NAME = NUMBER; the human
// text stays on the host, which keeps it out of the boards' flash.
#ifndef WC_CODES_H
#define WC_CODES_H

enum wc_code {
#define X(kind, number, name, text) kind##_##name = number,
#include "protocol_codes.def"
#undef X
};

#endif
