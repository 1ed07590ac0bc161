// whisker_nano: streams the MLX90393 under the whisker at 300 Hz as CRC-checked frames.
// Protocol: docs/protocol.md ("Sensor"); wiring, settings and timing: docs/firmware.md.
// Build with `make firmware` (it adds the include paths of the shared code table).
#include <Arduino.h>
#include <Wire.h>

#include "wn_command.h"
#include "wn_sampler.h"

static sampler_state sampler;
static command_reader reader;

void setup() {
    Serial.begin(115200);
    Wire.begin();
    Wire.setClock(400000);
    // NOTE: a missing sensor must not hang the loop: give up on a stuck bus after 2 ms.
    Wire.setWireTimeout(2000, true);
    sampler_init(sampler);
    command_reader_init(reader);
}

void loop() {
    while (Serial.available() > 0) command_receive(reader, (char)Serial.read(), sampler, micros());
    sampler_poll(sampler, micros());
}
