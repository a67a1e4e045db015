/**
 * @file forte_device.c
 * @brief Board-independent device logic (see forte_device.h).
 */
#include "forte_device.h"

#include <string.h>

/* ---- normalisation --------------------------------------------------------------- */

int16_t forte_normalise_code(int32_t code, const forte_calibration_t *calibration, bool *clipped)
{
    const int64_t half_span = calibration->half_span_code > 0 ? calibration->half_span_code : 1;
    const int64_t numerator = (int64_t)(code - calibration->zero_code) * FORTE_COUNTS_PER_FULL_SCALE;
    /* round half away from zero: (2n + sign*d) / (2d), C division truncates toward zero */
    const int64_t sign = numerator < 0 ? -1 : 1;
    int64_t value = (2 * numerator + sign * half_span) / (2 * half_span);
    bool was_clipped = false;
    if (value > FORTE_COUNTS_PER_FULL_SCALE) {
        value = FORTE_COUNTS_PER_FULL_SCALE;
        was_clipped = true;
    } else if (value < -FORTE_COUNTS_PER_FULL_SCALE) {
        value = -FORTE_COUNTS_PER_FULL_SCALE;
        was_clipped = true;
    }
    if (clipped != NULL) {
        *clipped = was_clipped;
    }
    return (int16_t)value;
}

/* ---- ring ------------------------------------------------------------------------- */

void forte_ring_init(forte_ring_t *ring)
{
    atomic_store_explicit(&ring->head, 0u, memory_order_relaxed);
    atomic_store_explicit(&ring->tail, 0u, memory_order_relaxed);
}

bool forte_ring_push(forte_ring_t *ring, const forte_sample_t *sample)
{
    const unsigned head = atomic_load_explicit(&ring->head, memory_order_relaxed);
    const unsigned tail = atomic_load_explicit(&ring->tail, memory_order_acquire);
    if (head - tail >= FORTE_RING_CAPACITY) {
        return false;
    }
    ring->slots[head & (FORTE_RING_CAPACITY - 1u)] = *sample;
    atomic_store_explicit(&ring->head, head + 1u, memory_order_release);
    return true;
}

bool forte_ring_pop(forte_ring_t *ring, forte_sample_t *sample)
{
    const unsigned tail = atomic_load_explicit(&ring->tail, memory_order_relaxed);
    const unsigned head = atomic_load_explicit(&ring->head, memory_order_acquire);
    if (head == tail) {
        return false;
    }
    *sample = ring->slots[tail & (FORTE_RING_CAPACITY - 1u)];
    atomic_store_explicit(&ring->tail, tail + 1u, memory_order_release);
    return true;
}

unsigned forte_ring_count(forte_ring_t *ring)
{
    return atomic_load_explicit(&ring->head, memory_order_acquire) -
           atomic_load_explicit(&ring->tail, memory_order_acquire);
}

/* ---- rate bookkeeping ----------------------------------------------------------------- */

bool forte_rate_valid(uint32_t rate_hz, uint32_t *period_us)
{
    if (rate_hz < FORTE_RATE_MIN_HZ || rate_hz > FORTE_RATE_MAX_HZ || 1000000u % rate_hz != 0u) {
        return false;
    }
    if (period_us != NULL) {
        *period_us = 1000000u / rate_hz;
    }
    return true;
}

void forte_schedule_start(forte_schedule_t *schedule, uint64_t first_alarm_us, uint32_t period_us)
{
    schedule->next_alarm_us = first_alarm_us;
    schedule->period_us = period_us;
}

uint32_t forte_schedule_advance(forte_schedule_t *schedule, uint64_t now_us,
                                uint64_t *scan_time_us)
{
    uint64_t missed = 0;
    if (now_us >= schedule->next_alarm_us + schedule->period_us) {
        missed = (now_us - schedule->next_alarm_us) / schedule->period_us;
    }
    const uint64_t scan_time = schedule->next_alarm_us + missed * schedule->period_us;
    if (scan_time_us != NULL) {
        *scan_time_us = scan_time;
    }
    schedule->next_alarm_us = scan_time + schedule->period_us;
    return (uint32_t)missed;
}

/* ---- device ----------------------------------------------------------------------- */

void forte_device_init(forte_device_t *device)
{
    memset(device, 0, sizeof(*device));
    forte_ring_init(&device->ring);
    for (int k = 0; k < FORTE_CHANNEL_COUNT; ++k) {
        device->calibration[k].zero_code = 2048;
        device->calibration[k].half_span_code = 2048;
    }
    device->rate_hz = FORTE_RATE_DEFAULT_HZ;
    (void)forte_rate_valid(device->rate_hz, &device->period_us);
    atomic_store(&device->overruns, 0u);
}

void forte_device_on_tick(forte_device_t *device, uint64_t time_us,
                          const int32_t codes[FORTE_CHANNEL_COUNT], uint32_t missed)
{
    if (!device->streaming) {
        return;
    }
    if (missed > 0u) {
        atomic_fetch_add(&device->overruns, missed);
        device->next_sequence += missed;
    }
    forte_sample_t sample;
    memset(&sample, 0, sizeof(sample));
    sample.sequence = device->next_sequence++;
    sample.time_us = time_us;
    for (int k = 0; k < FORTE_CHANNEL_COUNT; ++k) {
        bool clipped = false;
        sample.values[k] = forte_normalise_code(codes[k], &device->calibration[k], &clipped);
        if (clipped) {
            sample.saturated |= (uint8_t)(1u << k);
        }
    }
    const unsigned overruns = atomic_load(&device->overruns);
    sample.overruns = (uint16_t)overruns;
    if (sample.saturated != 0u) {
        sample.flags |= FORTE_FLAG_SATURATED;
    }
    if (overruns != device->overruns_reported) {
        sample.flags |= FORTE_FLAG_OVERRUN;
    }
    if (device->session_start) {
        sample.flags |= FORTE_FLAG_SESSION_START;
    }
    if (forte_ring_push(&device->ring, &sample)) {
        device->overruns_reported = overruns;
        device->session_start = false;
    } else {
        atomic_fetch_add(&device->overruns, 1u);
    }
}

forte_action_t forte_device_handle_command(forte_device_t *device, const forte_command_t *command,
                                           forte_ack_t *ack)
{
    memset(ack, 0, sizeof(*ack));
    ack->command = command->command;
    ack->token = command->token;
    ack->status = FORTE_STATUS_OK;
    switch (command->command) {
    case FORTE_COMMAND_START:
        if (device->streaming) {
            ack->status = FORTE_STATUS_BUSY;
            return FORTE_ACTION_NONE;
        }
        /* the sampling interrupt is stopped here: safe to reset its state */
        forte_ring_init(&device->ring);
        device->next_sequence = 0;
        atomic_store(&device->overruns, 0u);
        device->overruns_reported = 0;
        device->session_start = true;
        device->samples_sent = 0;
        ack->value = device->rate_hz;
        device->streaming = true;
        return FORTE_ACTION_START_SAMPLING;
    case FORTE_COMMAND_STOP:
        ack->value = device->next_sequence;
        if (!device->streaming) {
            return FORTE_ACTION_NONE;
        }
        device->streaming = false;
        return FORTE_ACTION_STOP_SAMPLING;
    case FORTE_COMMAND_IDENTIFY:
        ack->value = device->rate_hz;
        return FORTE_ACTION_SEND_INFO;
    case FORTE_COMMAND_SET_RATE: {
        uint32_t period_us = 0;
        if (device->streaming) {
            ack->status = FORTE_STATUS_BUSY;
        } else if (!forte_rate_valid(command->argument, &period_us)) {
            ack->status = FORTE_STATUS_BAD_ARGUMENT;
        } else {
            device->rate_hz = command->argument;
            device->period_us = period_us;
        }
        ack->value = device->rate_hz;
        return FORTE_ACTION_NONE;
    }
    default:
        ack->status = FORTE_STATUS_UNKNOWN_COMMAND;
        return FORTE_ACTION_NONE;
    }
}

void forte_device_info(const forte_device_t *device, uint64_t device_id, forte_info_t *info)
{
    memset(info, 0, sizeof(*info));
    info->protocol_version = FORTE_PROTOCOL_VERSION;
    info->firmware_major = 1;
    info->firmware_minor = 0;
    info->firmware_patch = 0;
    info->channel_count = FORTE_CHANNEL_COUNT;
    info->adc_bits = 12;
    info->counts_per_full_scale = FORTE_COUNTS_PER_FULL_SCALE;
    info->rate_hz = (uint16_t)device->rate_hz;
    info->ring_capacity = (uint16_t)FORTE_RING_CAPACITY;
    info->device_id = device_id;
}

/* ---- transmit staging --------------------------------------------------------------- */

void forte_tx_init(forte_tx_t *tx)
{
    tx->length = 0;
    tx->written = 0;
}

size_t forte_tx_space(forte_tx_t *tx)
{
    if (tx->written > 0) {
        memmove(tx->bytes, tx->bytes + tx->written, tx->length - tx->written);
        tx->length -= tx->written;
        tx->written = 0;
    }
    return FORTE_TX_CAPACITY - tx->length;
}

bool forte_tx_stage(forte_tx_t *tx, const uint8_t *frame, size_t length)
{
    if (forte_tx_space(tx) < length) {
        return false;
    }
    memcpy(tx->bytes + tx->length, frame, length);
    tx->length += length;
    return true;
}

size_t forte_tx_pending(const forte_tx_t *tx, const uint8_t **data)
{
    *data = tx->bytes + tx->written;
    return tx->length - tx->written;
}

void forte_tx_consumed(forte_tx_t *tx, size_t count)
{
    const size_t pending = tx->length - tx->written;
    tx->written += count < pending ? count : pending;
}

unsigned forte_device_stage_samples(forte_device_t *device, forte_tx_t *tx)
{
    unsigned staged = 0;
    uint8_t frame[FORTE_SAMPLE_FRAME_SIZE];
    while (forte_tx_space(tx) >= FORTE_SAMPLE_FRAME_SIZE) {
        forte_sample_t sample;
        if (!forte_ring_pop(&device->ring, &sample)) {
            break;
        }
        const size_t length = forte_encode_sample(&sample, frame, sizeof(frame));
        (void)forte_tx_stage(tx, frame, length);
        device->samples_sent += 1;
        staged += 1;
    }
    return staged;
}
