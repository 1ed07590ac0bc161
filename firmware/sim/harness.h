// The emulation harness: an ATmega328P in simavr running a sketch's .hex, coupled to the host
// (whiskercal's twin) by a line protocol on stdin/stdout (docs/firmware.md, "Emulation"):
//
//   host -> harness                         harness -> host
//   R <cycle>    run the AVR to <cycle>     U <cycle> <byte>   a byte the UART sent (hex)
//                                           F <cycle> <gain> <res> <osr> <filt>
//                                                              the MLX90393 starts a conversion:
//                                                              the host answers one line
//                                                              "<x> <y> <z> <conversion µs>"
//                                           K <cycle>          the run (or input) is done
//   I <hex>      bytes into the UART        K <cycle>
//   (stage)                                 P <cycle> <x> <y> <z>  motor steps, before each run's K
//   L <x> <y>    where the limit switches   A <cycle> <axis> <x> <y>  an AS5600 is read (with the
//                close, in motor steps          step counters): the host answers
//                                               "<status> <raw angle>" or "nack"
//   E            the EEPROM                 E <cycle> <1024 bytes in hex>, then K
//   W <hex>      write the EEPROM           K
//   M            stack use                  M <cycle> <stack bytes> <never used bytes>, then K
//   V            interrupt latency          V <vector> <calls> <longest> <total> (cycles from the
//                                             flag to the vector's call) per vector, then K
//   Q            quit
//
// The harness only advances the AVR when told to, so emulated time is the host's to keep.
#ifndef WC_SIM_HARNESS_H
#define WC_SIM_HARNESS_H

#include <stdint.h>
#include <stdio.h>

#include <sim_avr.h>

enum { HARNESS_LINE_MAX = 512 };

// The host's answer to a request line (the request is flushed first); exits when the host is gone.
void harness_ask(const char* request, char* answer, size_t size);

// A line to the host, in order with the UART bytes.
void harness_say(const char* line);

#endif
