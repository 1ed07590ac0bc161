#include "stepper.h"

#include <math.h>

#include "hal.h"
#include "planner.h"
#include "settings.h"

struct stepper_block {
    uint32_t steps[AXIS_COUNT];
    uint32_t step_event_count;
    uint8_t direction_bits;
    uint8_t kind;
};

struct stepper_segment {
    uint16_t period_ticks;
    uint16_t step_events;    // 0: a pause of one period (dwell, slow start)
    uint16_t speed_mm_min;
    uint8_t block_index;
    bool first_of_block;
};

// Shared between the main loop (producer) and the ISR (consumer).
static stepper_block stepper_blocks[SEGMENT_BUFFER_SIZE];
static stepper_segment stepper_segments[SEGMENT_BUFFER_SIZE];
static volatile uint8_t stepper_segment_head;
static volatile uint8_t stepper_segment_tail;
static volatile bool stepper_running;
static volatile int32_t stepper_steps[AXIS_COUNT];
static volatile uint16_t stepper_speed;
static volatile uint8_t stepper_limit_hits;

// ISR only.
static stepper_segment stepper_exec;
static const stepper_block* stepper_exec_block;
static uint16_t stepper_exec_events_left;
static bool stepper_exec_active;
static uint32_t stepper_counter[AXIS_COUNT];

// Main loop only.
struct stepper_prep_state {
    planner_block* block;
    uint8_t block_index;
    bool first_of_block;
    float mm_remaining;
    uint32_t events_remaining;
    float speed_mm_s;
    float dwell_remaining_s;
    bool hold;
    bool hold_reached;
};
static stepper_prep_state stepper_prep_data;

static uint8_t stepper_next_segment(uint8_t index) { return (uint8_t)((index + 1) % SEGMENT_BUFFER_SIZE); }

// Decelerating: uniformly to a stop exactly at the end of the block, never harder than accel.
static float stepper_brake(float v0, float mm_remaining, float accel, stepper_segment_plan& plan) {
    float needed = v0 * v0 / (2.0f * mm_remaining);
    float decel = needed < accel ? needed : accel;
    float v1 = v0 - decel * SEGMENT_S;
    if (v1 <= 0.0f) {
        v1 = 0.0f;
        plan.seconds = v0 / decel;
    }
    return v1;
}

// Accelerating or cruising, unless even cruising for a segment would leave too little room to
// stop: then braking starts now.
static float stepper_drive(float v0, float mm_remaining, float nominal, float accel, stepper_segment_plan& plan) {
    // Fastest end speed v1 from which the stage can still stop in what is left after this
    // segment: v1^2 <= 2 a (s - (v0 + v1) dt / 2), the positive root of that quadratic.
    float a_dt = accel * SEGMENT_S;
    float discriminant = a_dt * a_dt - 4.0f * (a_dt * v0 - 2.0f * accel * mm_remaining);
    float cap = discriminant > 0.0f ? 0.5f * (-a_dt + sqrtf(discriminant)) : 0.0f;
    if (v0 > 0.0f && cap < v0) return stepper_brake(v0, mm_remaining, accel, plan);
    float target = nominal < cap ? nominal : cap;
    return v0 < target ? fminf(v0 + a_dt, target) : fmaxf(v0 - a_dt, target);
}

stepper_segment_plan stepper_plan_segment(float v0, float mm_remaining, float nominal, float accel, bool hold) {
    stepper_segment_plan plan = {0.0f, 0.0f, SEGMENT_S, false, false};
    float v1;
    if (hold) {
        v1 = v0 - accel * SEGMENT_S;
        if (v1 <= 0.0f) {
            v1 = 0.0f;
            plan.seconds = v0 / accel;
            plan.stopped = true;
        }
    } else {
        v1 = stepper_drive(v0, mm_remaining, nominal, accel, plan);
    }
    plan.mm = 0.5f * (v0 + v1) * plan.seconds;
    // NOTE: 1e-5 mm is far below a step (12.5 µm) and above float rounding of 200 mm.
    if (plan.mm >= mm_remaining - 1.0e-5f) {
        plan.mm = mm_remaining;
        plan.block_done = true;
        plan.stopped = hold;
        if (v0 + v1 > 0.0f) plan.seconds = 2.0f * mm_remaining / (v0 + v1);
    }
    plan.speed_end_mm_s = plan.block_done ? 0.0f : v1;
    return plan;
}

void stepper_init() {
    for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) stepper_steps[axis] = 0;
    stepper_reset();
}

void stepper_reset() {
    hal_step_timer_stop();
    stepper_running = false;
    stepper_segment_head = stepper_segment_tail = 0;
    stepper_exec_active = false;
    stepper_speed = 0;
    stepper_limit_hits = 0;
    stepper_prep_data = stepper_prep_state();
    stepper_prep_data.block_index = 0;
}

static bool stepper_load_block(stepper_prep_state& prep) {
    prep.block = planner_current();
    if (!prep.block) return false;
    prep.block_index = (uint8_t)((prep.block_index + 1) % SEGMENT_BUFFER_SIZE);
    stepper_block& target = stepper_blocks[prep.block_index];
    for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) target.steps[axis] = prep.block->steps[axis];
    target.step_event_count = prep.block->step_event_count;
    target.direction_bits = prep.block->direction_bits;
    target.kind = prep.block->kind;
    prep.first_of_block = true;
    prep.mm_remaining = prep.block->millimeters;
    prep.events_remaining = prep.block->step_event_count;
    prep.speed_mm_s = 0.0f;
    prep.dwell_remaining_s = prep.block->dwell_s;
    return true;
}

static uint16_t stepper_ticks(float seconds, uint32_t events) {
    float ticks = seconds * (float)STEP_TIMER_HZ / (float)(events ? events : 1);
    if (ticks < STEP_PERIOD_MIN_TICKS) return STEP_PERIOD_MIN_TICKS;
    if (ticks > 65535.0f) return 65535;
    return (uint16_t)ticks;
}

static void stepper_push(stepper_prep_state& prep, float seconds, uint32_t events, float speed_mm_s) {
    stepper_segment& segment = stepper_segments[stepper_segment_head];
    segment.period_ticks = stepper_ticks(seconds, events);
    segment.step_events = (uint16_t)events;
    segment.speed_mm_min = (uint16_t)(speed_mm_s * 60.0f + 0.5f);
    segment.block_index = prep.block_index;
    segment.first_of_block = prep.first_of_block;
    prep.first_of_block = false;
    stepper_segment_head = stepper_next_segment(stepper_segment_head);
}

static void stepper_finish_block(stepper_prep_state& prep) {
    planner_discard();
    prep.block = 0;
    prep.speed_mm_s = 0.0f;
}

static void stepper_prep_dwell(stepper_prep_state& prep) {
    if (prep.hold) {
        prep.hold_reached = true;  // a dwell pauses where it is
        return;
    }
    float seconds = prep.dwell_remaining_s < SEGMENT_S ? prep.dwell_remaining_s : SEGMENT_S;
    stepper_push(prep, seconds, 0, 0.0f);
    prep.dwell_remaining_s -= seconds;
    if (prep.dwell_remaining_s <= 1.0e-6f) stepper_finish_block(prep);
}

static void stepper_prep_move(stepper_prep_state& prep) {
    const planner_block& block = *prep.block;
    stepper_segment_plan plan = stepper_plan_segment(prep.speed_mm_s, prep.mm_remaining, block.nominal_speed_mm_s,
                                                     block.accel_mm_s2, prep.hold);
    prep.mm_remaining -= plan.mm;
    uint32_t events_after = 0;
    if (!plan.block_done) {
        events_after = (uint32_t)((float)block.step_event_count * (prep.mm_remaining / block.millimeters) + 0.5f);
        if (events_after > prep.events_remaining) events_after = prep.events_remaining;
    }
    uint32_t events = prep.events_remaining - events_after;
    prep.events_remaining = events_after;
    float mean_speed = plan.seconds > 0.0f ? plan.mm / plan.seconds : 0.0f;
    if (events > 0 || plan.seconds > 1.0e-4f) stepper_push(prep, plan.seconds, events, mean_speed);
    prep.speed_mm_s = plan.speed_end_mm_s;
    if (plan.stopped) prep.hold_reached = true;
    if (plan.block_done) stepper_finish_block(prep);
}

void stepper_prep() {
    stepper_prep_state& prep = stepper_prep_data;
    while (!prep.hold_reached && stepper_next_segment(stepper_segment_head) != stepper_segment_tail) {
        if (!prep.block && !stepper_load_block(prep)) break;
        if (prep.block->kind == BLOCK_DWELL) {
            stepper_prep_dwell(prep);
        } else {
            stepper_prep_move(prep);
        }
    }
    // After a switch stopped the motion nothing restarts until the owner resets the stepper.
    if (!stepper_running && !stepper_limit_hits && stepper_segment_head != stepper_segment_tail) {
        stepper_running = true;
        hal_step_timer_start(stepper_segments[stepper_segment_tail].period_ticks);
    }
}

static bool stepper_exec_load() {
    uint8_t tail = stepper_segment_tail;
    if (tail == stepper_segment_head) {
        hal_step_timer_stop();
        stepper_running = false;
        stepper_speed = 0;
        return false;
    }
    stepper_exec = stepper_segments[tail];  // NOTE: copied once; the main loop may refill the slot
    stepper_exec_block = &stepper_blocks[stepper_exec.block_index];
    if (stepper_exec.first_of_block) {
        for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) stepper_counter[axis] = stepper_exec_block->step_event_count >> 1;
    }
    stepper_exec_events_left = stepper_exec.step_events ? stepper_exec.step_events : 1;
    stepper_speed = stepper_exec.speed_mm_min;
    hal_step_timer_set(stepper_exec.period_ticks);
    stepper_exec_active = true;
    return true;
}

// Bits of the axes that step on this event (Bresenham along the major axis).
static uint8_t stepper_bresenham() {
    uint8_t bits = 0;
    for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) {
        stepper_counter[axis] += stepper_exec_block->steps[axis];
        if (stepper_counter[axis] >= stepper_exec_block->step_event_count) {
            stepper_counter[axis] -= stepper_exec_block->step_event_count;
            bits |= (uint8_t)(1 << axis);
        }
    }
    return bits;
}

// A switch closing on an axis that moves towards it stops everything (homing or hard limit).
static bool stepper_limit_stop(uint8_t step_bits, uint8_t direction_bits) {
    uint8_t approaching = (uint8_t)(step_bits & direction_bits);
    if (!approaching || !(settings.homing || stepper_exec_block->kind == BLOCK_HOMING)) return false;
    uint8_t hits = 0;
    for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) {
        if ((approaching & (1 << axis)) && hal_limit_pressed(axis)) hits |= (uint8_t)(1 << axis);
    }
    if (!hits) return false;
    stepper_limit_hits |= hits;
    hal_step_timer_stop();
    stepper_running = false;
    stepper_exec_active = false;
    stepper_speed = 0;
    return true;
}

void stepper_isr() {
    if (!stepper_exec_active && !stepper_exec_load()) return;
    if (stepper_exec.step_events) {
        uint8_t bits = stepper_bresenham();
        uint8_t directions = stepper_exec_block->direction_bits;
        if (stepper_limit_stop(bits, directions)) return;
        hal_step_pulse(bits, directions);
        for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) {
            if (bits & (1 << axis)) stepper_steps[axis] += (directions & (1 << axis)) ? -1 : 1;
        }
    }
    if (--stepper_exec_events_left == 0) {
        stepper_exec_active = false;
        stepper_segment_tail = stepper_next_segment(stepper_segment_tail);
    }
}

void stepper_hold() { stepper_prep_data.hold = true; }

void stepper_resume() {
    stepper_prep_data.hold = false;
    stepper_prep_data.hold_reached = false;
}

bool stepper_holding() { return stepper_prep_data.hold; }

bool stepper_hold_complete() { return stepper_prep_data.hold_reached && !stepper_running; }

bool stepper_busy() {
    return stepper_running || stepper_segment_head != stepper_segment_tail || stepper_prep_data.block != 0 ||
           !planner_empty();
}

void stepper_position(int32_t out[AXIS_COUNT]) {
    hal_interrupts_off();
    for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) out[axis] = stepper_steps[axis];
    hal_interrupts_on();
}

void stepper_set_position(const int32_t position[AXIS_COUNT]) {
    hal_interrupts_off();
    for (uint8_t axis = 0; axis < AXIS_COUNT; ++axis) stepper_steps[axis] = position[axis];
    hal_interrupts_on();
}

uint16_t stepper_speed_mm_min() { return stepper_speed; }

uint8_t stepper_take_limit_hits() {
    hal_interrupts_off();
    uint8_t hits = stepper_limit_hits;
    stepper_limit_hits = 0;
    hal_interrupts_on();
    return hits;
}
