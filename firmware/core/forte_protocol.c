/**
 * @file forte_protocol.c
 * @brief Frame encoders and the streaming decoder of the FORTE serial protocol v1.
 */
#include "forte_protocol.h"

#include <string.h>

#include "forte_crc.h"

/* ---- little-endian field access ---------------------------------------------------- */

static void put_u16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)(v & 0xFFu);
    p[1] = (uint8_t)(v >> 8);
}

static void put_u32(uint8_t *p, uint32_t v)
{
    for (int i = 0; i < 4; ++i) {
        p[i] = (uint8_t)(v >> (8 * i));
    }
}

static void put_u64(uint8_t *p, uint64_t v)
{
    for (int i = 0; i < 8; ++i) {
        p[i] = (uint8_t)(v >> (8 * i));
    }
}

static uint16_t get_u16(const uint8_t *p)
{
    return (uint16_t)(p[0] | (p[1] << 8));
}

static uint32_t get_u32(const uint8_t *p)
{
    uint32_t v = 0;
    for (int i = 3; i >= 0; --i) {
        v = (v << 8) | p[i];
    }
    return v;
}

static uint64_t get_u64(const uint8_t *p)
{
    uint64_t v = 0;
    for (int i = 7; i >= 0; --i) {
        v = (v << 8) | p[i];
    }
    return v;
}

size_t forte_payload_size(uint8_t type)
{
    switch (type) {
    case FORTE_TYPE_SAMPLE:
        return FORTE_SAMPLE_PAYLOAD_SIZE;
    case FORTE_TYPE_COMMAND:
        return FORTE_COMMAND_PAYLOAD_SIZE;
    case FORTE_TYPE_ACK:
        return FORTE_ACK_PAYLOAD_SIZE;
    case FORTE_TYPE_INFO:
        return FORTE_INFO_PAYLOAD_SIZE;
    default:
        return 0;
    }
}

/* Write header and CRC around a payload already placed at out + FORTE_HEADER_SIZE. */
static size_t finish_frame(uint8_t type, uint8_t *out)
{
    const size_t payload = forte_payload_size(type);
    out[0] = FORTE_SYNC0;
    out[1] = FORTE_SYNC1;
    out[2] = FORTE_PROTOCOL_VERSION;
    out[3] = type;
    out[4] = (uint8_t)payload;
    const uint16_t crc = forte_crc16(out + 2, 3u + payload);
    put_u16(out + FORTE_HEADER_SIZE + payload, crc);
    return FORTE_FRAME_SIZE(payload);
}

size_t forte_encode_sample(const forte_sample_t *sample, uint8_t *out, size_t out_capacity)
{
    if (out_capacity < FORTE_SAMPLE_FRAME_SIZE) {
        return 0;
    }
    uint8_t *p = out + FORTE_HEADER_SIZE;
    put_u32(p + 0, sample->sequence);
    put_u64(p + 4, sample->time_us);
    for (int k = 0; k < FORTE_CHANNEL_COUNT; ++k) {
        put_u16(p + 12 + 2 * k, (uint16_t)sample->values[k]);
    }
    put_u16(p + 24, sample->overruns);
    p[26] = sample->flags;
    p[27] = sample->saturated;
    return finish_frame(FORTE_TYPE_SAMPLE, out);
}

size_t forte_encode_command(const forte_command_t *command, uint8_t *out, size_t out_capacity)
{
    if (out_capacity < FORTE_FRAME_SIZE(FORTE_COMMAND_PAYLOAD_SIZE)) {
        return 0;
    }
    uint8_t *p = out + FORTE_HEADER_SIZE;
    p[0] = command->command;
    p[1] = command->token;
    put_u16(p + 2, command->argument);
    return finish_frame(FORTE_TYPE_COMMAND, out);
}

size_t forte_encode_ack(const forte_ack_t *ack, uint8_t *out, size_t out_capacity)
{
    if (out_capacity < FORTE_FRAME_SIZE(FORTE_ACK_PAYLOAD_SIZE)) {
        return 0;
    }
    uint8_t *p = out + FORTE_HEADER_SIZE;
    p[0] = ack->command;
    p[1] = ack->token;
    p[2] = ack->status;
    p[3] = ack->reserved;
    put_u32(p + 4, ack->value);
    return finish_frame(FORTE_TYPE_ACK, out);
}

size_t forte_encode_info(const forte_info_t *info, uint8_t *out, size_t out_capacity)
{
    if (out_capacity < FORTE_FRAME_SIZE(FORTE_INFO_PAYLOAD_SIZE)) {
        return 0;
    }
    uint8_t *p = out + FORTE_HEADER_SIZE;
    p[0] = info->protocol_version;
    p[1] = info->firmware_major;
    p[2] = info->firmware_minor;
    p[3] = info->firmware_patch;
    p[4] = info->channel_count;
    p[5] = info->adc_bits;
    put_u16(p + 6, info->counts_per_full_scale);
    put_u16(p + 8, info->rate_hz);
    put_u16(p + 10, info->ring_capacity);
    put_u64(p + 12, info->device_id);
    return finish_frame(FORTE_TYPE_INFO, out);
}

/* ---- decoder -------------------------------------------------------------------- */

static void parse_payload(uint8_t type, const uint8_t *p, forte_frame_t *frame)
{
    memset(frame, 0, sizeof(*frame));
    frame->type = type;
    switch (type) {
    case FORTE_TYPE_SAMPLE: {
        forte_sample_t *s = &frame->body.sample;
        s->sequence = get_u32(p + 0);
        s->time_us = get_u64(p + 4);
        for (int k = 0; k < FORTE_CHANNEL_COUNT; ++k) {
            s->values[k] = (int16_t)get_u16(p + 12 + 2 * k);
        }
        s->overruns = get_u16(p + 24);
        s->flags = p[26];
        s->saturated = p[27];
        break;
    }
    case FORTE_TYPE_COMMAND:
        frame->body.command.command = p[0];
        frame->body.command.token = p[1];
        frame->body.command.argument = get_u16(p + 2);
        break;
    case FORTE_TYPE_ACK:
        frame->body.ack.command = p[0];
        frame->body.ack.token = p[1];
        frame->body.ack.status = p[2];
        frame->body.ack.reserved = p[3];
        frame->body.ack.value = get_u32(p + 4);
        break;
    case FORTE_TYPE_INFO: {
        forte_info_t *i = &frame->body.info;
        i->protocol_version = p[0];
        i->firmware_major = p[1];
        i->firmware_minor = p[2];
        i->firmware_patch = p[3];
        i->channel_count = p[4];
        i->adc_bits = p[5];
        i->counts_per_full_scale = get_u16(p + 6);
        i->rate_hz = get_u16(p + 8);
        i->ring_capacity = get_u16(p + 10);
        i->device_id = get_u64(p + 12);
        break;
    }
    default:
        break;
    }
}

void forte_decoder_init(forte_decoder_t *decoder)
{
    memset(decoder, 0, sizeof(*decoder));
}

/* Drop the first n buffered bytes. */
static void drop_front(forte_decoder_t *decoder, size_t n)
{
    memmove(decoder->buffer, decoder->buffer + n, decoder->fill - n);
    decoder->fill -= n;
}

/* True if the buffered bytes are a prefix of the signature A5 5A 01. */
static bool signature_prefix_ok(const forte_decoder_t *decoder)
{
    static const uint8_t signature[3] = {FORTE_SYNC0, FORTE_SYNC1, FORTE_PROTOCOL_VERSION};
    const size_t n = decoder->fill < 3u ? decoder->fill : 3u;
    return memcmp(decoder->buffer, signature, n) == 0;
}

/* Examine the buffer; extract one frame if complete. Leaves the buffer as a consistent
 * partial candidate (or empty) when it returns false. */
static bool process_buffer(forte_decoder_t *decoder, forte_frame_t *frame)
{
    for (;;) {
        if (decoder->fill == 0) {
            return false;
        }
        if (!signature_prefix_ok(decoder)) {
            decoder->discarded_bytes += 1;
            drop_front(decoder, 1);
            continue;
        }
        if (decoder->fill < FORTE_HEADER_SIZE) {
            return false;
        }
        const uint8_t type = decoder->buffer[3];
        const size_t payload = forte_payload_size(type);
        if (payload == 0 || decoder->buffer[4] != payload) {
            decoder->corrupt_frames += 1;
            decoder->discarded_bytes += 1;
            drop_front(decoder, 1);
            continue;
        }
        const size_t frame_size = FORTE_FRAME_SIZE(payload);
        if (decoder->fill < frame_size) {
            return false;
        }
        const uint16_t expected = forte_crc16(decoder->buffer + 2, 3u + payload);
        const uint16_t received = get_u16(decoder->buffer + FORTE_HEADER_SIZE + payload);
        if (expected != received) {
            decoder->corrupt_frames += 1;
            decoder->discarded_bytes += 1;
            drop_front(decoder, 1);
            continue;
        }
        parse_payload(type, decoder->buffer + FORTE_HEADER_SIZE, frame);
        decoder->frames += 1;
        drop_front(decoder, frame_size);
        return true;
    }
}

bool forte_decoder_feed(forte_decoder_t *decoder, const uint8_t *data, size_t length,
                        forte_frame_t *frame, size_t *consumed)
{
    size_t used = 0;
    for (;;) {
        if (process_buffer(decoder, frame)) {
            *consumed = used;
            return true;
        }
        if (used == length) {
            break;
        }
        decoder->buffer[decoder->fill++] = data[used++];
    }
    *consumed = used;
    return false;
}
