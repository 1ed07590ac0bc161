// Frames of the sensor stream (docs/protocol.md, "Sensor"): sync A5 5A, type, length,
// payload, CRC-16/CCITT-FALSE over type, length and payload, all little-endian.
#ifndef WN_FRAME_H
#define WN_FRAME_H

#include <stdint.h>

enum : uint8_t {
    FRAME_SYNC_0 = 0xA5,
    FRAME_SYNC_1 = 0x5A,
    FRAME_TYPE_SAMPLE = 0x01,
    FRAME_TYPE_TEXT = 0x02,
    FRAME_OVERHEAD = 6,           // sync (2) + type + length + CRC (2)
    FRAME_SAMPLE_PAYLOAD = 13,
    FRAME_SAMPLE_SIZE = FRAME_SAMPLE_PAYLOAD + FRAME_OVERHEAD,
    FRAME_TEXT_MAX = 48,          // longest answer is "OK rate=... filt=..." (37 chars)
};

struct frame_sample {
    uint16_t seq;       // wraps; the host finds drops by gaps
    uint32_t t_us;      // board clock at the start of the conversion, µs (wraps)
    int16_t counts[3];  // x, y, z raw counts, offset removed so they are signed
    uint8_t status;     // SENSOR_STATUS bit mask
};

// CRC-16/CCITT-FALSE (poly 0x1021), continuing from crc (start with 0xFFFF).
uint16_t frame_crc16(const uint8_t* data, uint8_t n, uint16_t crc);

// Writes a complete frame to out (room for n + FRAME_OVERHEAD bytes); returns its length.
uint8_t frame_encode(uint8_t type, const uint8_t* payload, uint8_t n, uint8_t* out);

// Writes a complete 19-byte sample frame to out; returns its length.
uint8_t frame_encode_sample(const frame_sample& sample, uint8_t* out);

// Writes a text frame holding the NUL-terminated text (cut at FRAME_TEXT_MAX); returns its length.
uint8_t frame_encode_text(const char* text, uint8_t* out);

#endif
