"""Timing and memory figures of the compiled firmware, measured on simavr (docs/firmware.md,
"Emulation"): stack high-water mark of each sketch (painted SRAM read back), UART use at
300 frames/s, step-pulse jitter at the highest configured feed, and the time from a G-code line's
last byte to its answer. Needs `make firmware-sim`. Usage: python scripts/avr_figures.py
"""

from __future__ import annotations

import os
import tempfile

import numpy as np

from whiskercal.twin.devices.avr_harness import F_CPU_HZ, AvrHarness

# ATmega328P vector numbers of the interrupts the sketches use
VECTORS = {11: "TIMER1_COMPA (step)", 16: "TIMER0_OVF (micros)", 18: "USART_RX", 19: "USART_UDRE", 20: "USART_TX",
           24: "TWI"}
BAUD = 16_000_000 / (8 * 17)  # UBRR 16 with U2X: 117,647 baud
BYTE_CYCLES = 10 * F_CPU_HZ / BAUD


class Bench:
    """A harness with a clock in seconds and the UART's output kept as (cycle, byte)."""

    def __init__(self, board: str, responder) -> None:
        self.harness = AvrHarness(board, responder)
        self.sent: list[tuple[int, int]] = []

    def run(self, seconds: float) -> None:
        self.sent += self.harness.run_to(self.harness.cycle + int(seconds * F_CPU_HZ))

    def line(self, text: str, settle_s: float = 0.05) -> int:
        """Send a line; the cycle its last byte is in the AVR's receiver."""
        data = (text + "\n").encode()
        fed = self.harness.cycle
        self.harness.feed(data)
        self.run(settle_s)
        return fed + int(len(data) * BYTE_CYCLES)



def sensor_figures() -> dict:
    bench = Bench("sensor", lambda words: "100 -200 -16000 1840")
    bench.run(0.01)
    for text in ("ID", "CFG?", "GAIN 9", "X" * 40, "RATE 300"):
        bench.line(text)
    bench.sent.clear()
    started = bench.harness.cycle
    bench.line("START", 0.0)
    bench.run(3.0)
    bench.line("STOP")
    seconds = (bench.harness.cycle - started) / F_CPU_HZ
    busy = len(bench.sent) * BYTE_CYCLES / F_CPU_HZ / seconds
    stack, untouched = bench.harness.stack_use()
    return {**_latency("sensor", bench), "sensor_stack_bytes": stack, "sensor_sram_never_used": untouched,
            "uart_bytes_per_s": len(bench.sent) / seconds, "uart_busy_fraction": busy}


def _latency(board: str, bench: Bench) -> dict:
    """Longest and mean interrupt latency per vector, µs."""
    return {f"{board}_latency_us {VECTORS.get(vector, vector)}":
            f"longest {longest / 16:.2f}, mean {total / calls / 16:.2f} over {calls} calls"
            for vector, (calls, longest, total) in bench.harness.interrupt_latency().items()}


def _encoder_answer(words: list[str]) -> str:
    axis, steps = int(words[2]), int(words[3 + int(words[2])])
    return f"32 {round(steps / 80 / 40 * 4096) % 4096}"


def _answer_latency_ms(bench: Bench, text: str) -> float:
    bench.sent.clear()
    received = bench.line(text, 0.05)
    first = next(cycle for cycle, _ in bench.sent)
    return (first - received) / F_CPU_HZ * 1e3


def stage_figures() -> dict:
    log = tempfile.NamedTemporaryFile(suffix=".steps", delete=False)
    os.environ["WC_SIM_STEP_LOG"] = log.name
    try:
        bench = Bench("stage", _encoder_answer)
    finally:
        del os.environ["WC_SIM_STEP_LOG"]
    bench.harness.send_request("L -1680 -14480")  # the switches 1 mm below zero, from (20, 180) mm
    bench.run(0.2)
    latencies = {text: _answer_latency_ms(bench, text) for text in ("$X", "$$", "G90", "G1X0.5F600", "G4P0", "G1X1X2")}
    move_from = bench.harness.cycle
    bench.line("G1 X100 F3000", 0.0)  # the highest configured feed: 4,000 steps/s on X
    for _ in range(120):  # status polls every 20 ms, as a host does
        bench.line("?", 0.02)
    bench.run(0.5)
    move_to = bench.harness.cycle
    for text in ("$H", "?"):
        bench.line(text, 20.0 if text == "$H" else 0.05)
    stack, untouched = bench.harness.stack_use()
    latency = _latency("stage", bench)
    bench.harness.close()
    steps = np.loadtxt(log.name, dtype=np.int64, ndmin=2)
    os.unlink(log.name)
    return {**latency, "stage_stack_bytes": stack, "stage_sram_never_used": untouched,
            "answer_latency_ms": latencies, **_jitter(steps, move_from, move_to)}


def _jitter(steps: np.ndarray, move_from: int, move_to: int) -> dict:
    """Step intervals on X during the cruise of the 100 mm move (its middle half)."""
    x = steps[(steps[:, 0] == 0) & (steps[:, 1] >= move_from) & (steps[:, 1] <= move_to), 1]
    intervals = np.diff(x)
    cruise = intervals[len(intervals) // 4: 3 * len(intervals) // 4]
    nominal = np.median(cruise)
    return {"step_rate_hz": F_CPU_HZ / nominal,
            "step_interval_us": nominal / 16, "step_jitter_us_max": float(np.abs(cruise - nominal).max() / 16),
            "step_jitter_us_p99": float(np.percentile(np.abs(cruise - nominal), 99) / 16)}


if __name__ == "__main__":
    for name, value in {**sensor_figures(), **stage_figures()}.items():
        print(f"{name}: {value}")
