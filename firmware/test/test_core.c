/**
 * @file test_core.c
 * @brief Host unit tests of the portable FORTE firmware core (CRC, framing, decoder,
 *        normalisation, ring, scheduling, command handling, transmit staging) against the
 *        shared vectors in firmware/test_vectors and against each other end to end.
 *
 * Usage: test_core <vector folder>
 */
#include <inttypes.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "forte_crc.h"
#include "forte_device.h"
#include "forte_protocol.h"
#include "harness.h"

unsigned harness_passed = 0;
unsigned harness_failed = 0;

static const char *vector_folder = "test_vectors";

/* ---- helpers ------------------------------------------------------------------------ */

static FILE *open_vector_file(const char *name)
{
    char path[1024];
    snprintf(path, sizeof(path), "%s/%s", vector_folder, name);
    FILE *file = fopen(path, "r");
    if (file == NULL) {
        fprintf(stderr, "cannot open %s\n", path);
    }
    return file;
}

static size_t hex_to_bytes(const char *hex, uint8_t *out, size_t capacity)
{
    size_t n = 0;
    while (hex[0] != '\0' && hex[1] != '\0' && hex[0] != '\n' && n < capacity) {
        unsigned value = 0;
        if (sscanf(hex, "%2x", &value) != 1) {
            break;
        }
        out[n++] = (uint8_t)value;
        hex += 2;
    }
    return n;
}

/* Copy text into a fixed-size field, truncating (vectors are far shorter). */
static void copy_text(char *destination, size_t capacity, const char *source)
{
    size_t n = strlen(source);
    if (n >= capacity) {
        n = capacity - 1;
    }
    memcpy(destination, source, n);
    destination[n] = '\0';
}

static void strip_newline(char *line)
{
    size_t n = strlen(line);
    while (n > 0 && (line[n - 1] == '\n' || line[n - 1] == '\r' || line[n - 1] == ' ')) {
        line[--n] = '\0';
    }
}

/* Format a decoded frame exactly like the "frame ..." lines of decoder_vectors.txt. */
static void format_frame(const forte_frame_t *frame, char *out, size_t capacity)
{
    switch (frame->type) {
    case FORTE_TYPE_SAMPLE: {
        const forte_sample_t *s = &frame->body.sample;
        snprintf(out, capacity,
                 "frame sample seq=%" PRIu32 " time_us=%" PRIu64
                 " values=%d,%d,%d,%d,%d,%d overruns=%u flags=%u saturated=%u",
                 s->sequence, s->time_us, s->values[0], s->values[1], s->values[2], s->values[3],
                 s->values[4], s->values[5], s->overruns, s->flags, s->saturated);
        break;
    }
    case FORTE_TYPE_ACK: {
        const forte_ack_t *a = &frame->body.ack;
        snprintf(out, capacity, "frame ack command=%u token=%u status=%u value=%" PRIu32,
                 a->command, a->token, a->status, a->value);
        break;
    }
    case FORTE_TYPE_COMMAND: {
        const forte_command_t *c = &frame->body.command;
        snprintf(out, capacity, "frame command command=%u token=%u argument=%u", c->command,
                 c->token, c->argument);
        break;
    }
    case FORTE_TYPE_INFO: {
        const forte_info_t *i = &frame->body.info;
        snprintf(out, capacity,
                 "frame info protocol_version=%u firmware=%u.%u.%u channels=%u adc_bits=%u "
                 "counts_per_full_scale=%u rate_hz=%u ring_capacity=%u device_id=%" PRIu64,
                 i->protocol_version, i->firmware_major, i->firmware_minor, i->firmware_patch,
                 i->channel_count, i->adc_bits, i->counts_per_full_scale, i->rate_hz,
                 i->ring_capacity, i->device_id);
        break;
    }
    default:
        snprintf(out, capacity, "frame unknown type=%u", frame->type);
    }
}

static size_t encode_frame(const forte_frame_t *frame, uint8_t *out, size_t capacity)
{
    switch (frame->type) {
    case FORTE_TYPE_SAMPLE:
        return forte_encode_sample(&frame->body.sample, out, capacity);
    case FORTE_TYPE_ACK:
        return forte_encode_ack(&frame->body.ack, out, capacity);
    case FORTE_TYPE_COMMAND:
        return forte_encode_command(&frame->body.command, out, capacity);
    case FORTE_TYPE_INFO:
        return forte_encode_info(&frame->body.info, out, capacity);
    default:
        return 0;
    }
}

#define MAX_VECTOR_BYTES 4096
#define MAX_VECTOR_FRAMES 16
#define LINE_SIZE 4096

typedef struct {
    char name[128];
    uint8_t input[MAX_VECTOR_BYTES];
    size_t input_length;
    char frames[MAX_VECTOR_FRAMES][512];
    unsigned frame_count;
    unsigned expect_frames, expect_corrupt, expect_discarded, expect_pending;
} vector_t;

/* Feed the vector in chunks of chunk bytes (0 = all at once); check frames and counters. */
static void check_vector_with_chunks(const vector_t *vector, size_t chunk, unsigned *ok_vectors)
{
    forte_decoder_t decoder;
    forte_decoder_init(&decoder);
    char text[512];
    unsigned decoded = 0;
    uint8_t reencoded[MAX_VECTOR_BYTES];
    size_t reencoded_length = 0;
    bool all_match = true;
    size_t offset = 0;
    const size_t step = chunk == 0 ? (vector->input_length > 0 ? vector->input_length : 1) : chunk;
    do {
        size_t length = vector->input_length - offset;
        if (length > step) {
            length = step;
        }
        const uint8_t *data = vector->input + offset;
        size_t remaining = length;
        forte_frame_t frame;
        size_t consumed = 0;
        while (forte_decoder_feed(&decoder, data, remaining, &frame, &consumed)) {
            data += consumed;
            remaining -= consumed;
            format_frame(&frame, text, sizeof(text));
            if (decoded >= vector->frame_count || strcmp(text, vector->frames[decoded]) != 0) {
                all_match = false;
                fprintf(stderr, "vector %s (chunk %zu): frame %u decoded as\n  %s\n", vector->name,
                        chunk, decoded, text);
            }
            reencoded_length += encode_frame(&frame, reencoded + reencoded_length,
                                             sizeof(reencoded) - reencoded_length);
            decoded++;
        }
        offset += length;
    } while (offset < vector->input_length);
    CHECK(all_match);
    CHECK_EQ_INT(decoded, vector->frame_count);
    CHECK_EQ_INT(decoder.frames, vector->expect_frames);
    CHECK_EQ_INT(decoder.corrupt_frames, vector->expect_corrupt);
    CHECK_EQ_INT(decoder.discarded_bytes, vector->expect_discarded);
    CHECK_EQ_INT(decoder.fill, vector->expect_pending);
    /* every byte is accounted for exactly once */
    CHECK_EQ_INT(reencoded_length + decoder.discarded_bytes + decoder.fill, vector->input_length);
    if (vector->expect_corrupt == 0 && vector->expect_discarded == 0 && vector->expect_pending == 0) {
        /* a clean stream re-encodes to exactly the same bytes */
        CHECK(reencoded_length == vector->input_length &&
              memcmp(reencoded, vector->input, reencoded_length) == 0);
    }
    if (all_match && decoded == vector->frame_count &&
        decoder.corrupt_frames == vector->expect_corrupt &&
        decoder.discarded_bytes == vector->expect_discarded) {
        (*ok_vectors)++;
    } else {
        fprintf(stderr, "vector %s failed with chunk size %zu\n", vector->name, chunk);
    }
}

/* ---- tests ---------------------------------------------------------------------------- */

static void test_crc_vectors(void)
{
    FILE *file = open_vector_file("crc_vectors.txt");
    CHECK(file != NULL);
    if (file == NULL) {
        return;
    }
    char line[LINE_SIZE];
    char hex[LINE_SIZE];
    unsigned expected = 0;
    unsigned count = 0;
    static uint8_t bytes[2048];
    while (fgets(line, sizeof(line), file) != NULL) {
        if (sscanf(line, "crc %4095s %x", hex, &expected) != 2) {
            continue;
        }
        const size_t n = strcmp(hex, "-") == 0 ? 0 : hex_to_bytes(hex, bytes, sizeof(bytes));
        CHECK_EQ_INT(forte_crc16(bytes, n), expected);
        /* split computation gives the same result */
        const uint16_t first = forte_crc16_update(FORTE_CRC16_INIT, bytes, n / 2);
        CHECK_EQ_INT(forte_crc16_update(first, bytes + n / 2, n - n / 2), expected);
        count++;
    }
    fclose(file);
    CHECK(count >= 6);
    CHECK_EQ_INT(forte_crc16((const uint8_t *)"123456789", 9), 0x29B1);
}

static void test_decoder_vectors(void)
{
    FILE *file = open_vector_file("decoder_vectors.txt");
    CHECK(file != NULL);
    if (file == NULL) {
        return;
    }
    static vector_t vector;
    static char line[LINE_SIZE];
    unsigned vectors = 0;
    unsigned ok_vectors = 0;
    bool in_vector = false;
    while (fgets(line, sizeof(line), file) != NULL) {
        strip_newline(line);
        if (strncmp(line, "vector ", 7) == 0) {
            memset(&vector, 0, sizeof(vector));
            copy_text(vector.name, sizeof(vector.name), line + 7);
            in_vector = true;
        } else if (!in_vector) {
            continue;
        } else if (strncmp(line, "input", 5) == 0) {
            vector.input_length = strlen(line) > 6 ? hex_to_bytes(line + 6, vector.input,
                                                                   sizeof(vector.input))
                                                   : 0;
        } else if (strncmp(line, "frame ", 6) == 0 && vector.frame_count < MAX_VECTOR_FRAMES) {
            copy_text(vector.frames[vector.frame_count++], sizeof(vector.frames[0]), line);
        } else if (strncmp(line, "expect ", 7) == 0) {
            CHECK(sscanf(line, "expect frames=%u corrupt=%u discarded=%u pending=%u",
                         &vector.expect_frames, &vector.expect_corrupt, &vector.expect_discarded,
                         &vector.expect_pending) == 4);
        } else if (strcmp(line, "end") == 0) {
            vectors++;
            static const size_t chunks[] = {0, 1, 2, 3, 7, 35, 64};
            unsigned ok_chunks = 0;
            for (size_t c = 0; c < sizeof(chunks) / sizeof(chunks[0]); ++c) {
                check_vector_with_chunks(&vector, chunks[c], &ok_chunks);
            }
            if (ok_chunks == sizeof(chunks) / sizeof(chunks[0])) {
                ok_vectors++;
            }
            in_vector = false;
        }
    }
    fclose(file);
    CHECK(vectors >= 15);
    CHECK_EQ_INT(ok_vectors, vectors);
}

static void test_normalise_vectors(void)
{
    FILE *file = open_vector_file("normalise_vectors.txt");
    CHECK(file != NULL);
    if (file == NULL) {
        return;
    }
    char line[LINE_SIZE];
    unsigned count = 0;
    while (fgets(line, sizeof(line), file) != NULL) {
        int code, zero, half, expected, clipped_expected;
        if (line[0] == '#' ||
            sscanf(line, "%d %d %d %d %d", &code, &zero, &half, &expected, &clipped_expected) != 5) {
            continue;
        }
        const forte_calibration_t calibration = {zero, half};
        bool clipped = false;
        CHECK_EQ_INT(forte_normalise_code(code, &calibration, &clipped), expected);
        CHECK_EQ_INT(clipped, clipped_expected);
        count++;
    }
    fclose(file);
    CHECK(count >= 20);
}

static void test_normalise_is_monotonic_and_symmetric(void)
{
    const forte_calibration_t calibration = {2048, 2048};
    int previous = forte_normalise_code(0, &calibration, NULL);
    bool monotonic = true;
    bool symmetric = true;
    for (int code = 0; code <= 4095; ++code) {
        const int value = forte_normalise_code(code, &calibration, NULL);
        monotonic = monotonic && value >= previous && value <= previous + 1;
        previous = value;
        const int mirrored = forte_normalise_code(4096 - code, &calibration, NULL);
        symmetric = symmetric && value == -mirrored;
    }
    CHECK(monotonic);
    CHECK(symmetric);
}

static void test_ring_order_full_and_wrap(void)
{
    static forte_ring_t ring;
    forte_ring_init(&ring);
    forte_sample_t sample;
    memset(&sample, 0, sizeof(sample));
    CHECK(!forte_ring_pop(&ring, &sample));
    unsigned pushed = 0;
    for (unsigned i = 0; i < FORTE_RING_CAPACITY + 5u; ++i) {
        sample.sequence = i;
        if (forte_ring_push(&ring, &sample)) {
            pushed++;
        }
    }
    CHECK_EQ_INT(pushed, FORTE_RING_CAPACITY);
    CHECK_EQ_INT(forte_ring_count(&ring), FORTE_RING_CAPACITY);
    bool in_order = true;
    for (unsigned i = 0; i < FORTE_RING_CAPACITY; ++i) {
        in_order = in_order && forte_ring_pop(&ring, &sample) && sample.sequence == i;
    }
    CHECK(in_order);
    CHECK(!forte_ring_pop(&ring, &sample));
    /* many laps around the buffer, kept half full, preserve FIFO order */
    bool laps_ok = true;
    unsigned expected = 1000000u;
    forte_sample_t out;
    for (unsigned i = 0; i < 10u * FORTE_RING_CAPACITY; ++i) {
        sample.sequence = 1000000u + i;
        laps_ok = laps_ok && forte_ring_push(&ring, &sample);
        if (forte_ring_count(&ring) >= FORTE_RING_CAPACITY / 2u) {
            laps_ok = laps_ok && forte_ring_pop(&ring, &out) && out.sequence == expected;
            expected++;
        }
    }
    while (forte_ring_pop(&ring, &out)) {
        laps_ok = laps_ok && out.sequence == expected;
        expected++;
    }
    CHECK(laps_ok);
    CHECK_EQ_INT(expected, 1000000u + 10u * FORTE_RING_CAPACITY);
}

static void test_rate_validation(void)
{
    uint32_t period = 0;
    CHECK(forte_rate_valid(2000, &period));
    CHECK_EQ_INT(period, 500);
    CHECK(forte_rate_valid(4000, &period));
    CHECK_EQ_INT(period, 250);
    CHECK(forte_rate_valid(1, &period));
    CHECK_EQ_INT(period, 1000000);
    CHECK(forte_rate_valid(1000, &period));
    CHECK(!forte_rate_valid(0, &period));
    CHECK(!forte_rate_valid(3, &period));    /* 333333.3 us */
    CHECK(!forte_rate_valid(4001, &period));
    CHECK(!forte_rate_valid(5000, &period)); /* above the maximum */
    CHECK(!forte_rate_valid(1999, &period));
}

static void test_schedule_exact_and_missed(void)
{
    forte_schedule_t schedule;
    forte_schedule_start(&schedule, 1000, 500);
    uint64_t scan_time = 0;
    bool exact = true;
    /* interrupts arriving with up to 499 us latency never miss and never drift */
    for (uint64_t n = 0; n < 100000; ++n) {
        const uint64_t latency = (n * 7919u) % 500u;
        const uint32_t missed = forte_schedule_advance(&schedule, 1000 + n * 500 + latency, &scan_time);
        exact = exact && missed == 0 && scan_time == 1000 + n * 500;
    }
    CHECK(exact);
    CHECK_EQ_INT(schedule.next_alarm_us, 1000 + 100000ull * 500);
    /* an interrupt 1.2 ms late misses two scan instants */
    forte_schedule_start(&schedule, 0, 500);
    CHECK_EQ_INT(forte_schedule_advance(&schedule, 1200, &scan_time), 2);
    CHECK_EQ_INT(scan_time, 1000);
    CHECK_EQ_INT(schedule.next_alarm_us, 1500);
    CHECK_EQ_INT(forte_schedule_advance(&schedule, 1500, &scan_time), 0);
    CHECK_EQ_INT(scan_time, 1500);
}

static forte_action_t send_command(forte_device_t *device, uint8_t code, uint8_t token,
                                   uint16_t argument, forte_ack_t *ack)
{
    const forte_command_t command = {code, token, argument};
    return forte_device_handle_command(device, &command, ack);
}

static void test_device_commands(void)
{
    static forte_device_t device;
    forte_device_init(&device);
    forte_ack_t ack;
    CHECK_EQ_INT(send_command(&device, FORTE_COMMAND_IDENTIFY, 1, 0, &ack), FORTE_ACTION_SEND_INFO);
    CHECK_EQ_INT(ack.status, FORTE_STATUS_OK);
    CHECK_EQ_INT(ack.token, 1);
    CHECK_EQ_INT(ack.value, 2000);
    CHECK_EQ_INT(send_command(&device, FORTE_COMMAND_SET_RATE, 2, 3, &ack), FORTE_ACTION_NONE);
    CHECK_EQ_INT(ack.status, FORTE_STATUS_BAD_ARGUMENT);
    CHECK_EQ_INT(device.rate_hz, 2000);
    CHECK_EQ_INT(send_command(&device, FORTE_COMMAND_SET_RATE, 3, 1000, &ack), FORTE_ACTION_NONE);
    CHECK_EQ_INT(ack.status, FORTE_STATUS_OK);
    CHECK_EQ_INT(device.period_us, 1000);
    CHECK_EQ_INT(send_command(&device, FORTE_COMMAND_START, 4, 0, &ack),
                 FORTE_ACTION_START_SAMPLING);
    CHECK_EQ_INT(ack.status, FORTE_STATUS_OK);
    CHECK_EQ_INT(ack.value, 1000);
    CHECK(device.streaming);
    CHECK_EQ_INT(send_command(&device, FORTE_COMMAND_START, 5, 0, &ack), FORTE_ACTION_NONE);
    CHECK_EQ_INT(ack.status, FORTE_STATUS_BUSY);
    CHECK_EQ_INT(send_command(&device, FORTE_COMMAND_SET_RATE, 6, 2000, &ack), FORTE_ACTION_NONE);
    CHECK_EQ_INT(ack.status, FORTE_STATUS_BUSY);
    CHECK_EQ_INT(device.rate_hz, 1000);
    const int32_t codes[6] = {2048, 2048, 2048, 2048, 2048, 2048};
    for (int i = 0; i < 7; ++i) {
        forte_device_on_tick(&device, 1000u * (uint64_t)i, codes, 0);
    }
    CHECK_EQ_INT(send_command(&device, FORTE_COMMAND_STOP, 7, 0, &ack), FORTE_ACTION_STOP_SAMPLING);
    CHECK_EQ_INT(ack.value, 7);
    CHECK(!device.streaming);
    forte_device_on_tick(&device, 99999, codes, 0); /* ignored when stopped */
    CHECK_EQ_INT(forte_ring_count(&device.ring), 7);
    CHECK_EQ_INT(send_command(&device, FORTE_COMMAND_STOP, 8, 0, &ack), FORTE_ACTION_NONE);
    CHECK_EQ_INT(ack.status, FORTE_STATUS_OK);
    CHECK_EQ_INT(send_command(&device, 0x77, 9, 0, &ack), FORTE_ACTION_NONE);
    CHECK_EQ_INT(ack.status, FORTE_STATUS_UNKNOWN_COMMAND);
    CHECK_EQ_INT(ack.command, 0x77);
    forte_info_t info;
    forte_device_info(&device, 42, &info);
    CHECK_EQ_INT(info.rate_hz, 1000);
    CHECK_EQ_INT(info.channel_count, 6);
    CHECK_EQ_INT(info.device_id, 42);
}

static void test_device_overruns_are_counted_and_never_block(void)
{
    static forte_device_t device;
    forte_device_init(&device);
    forte_ack_t ack;
    send_command(&device, FORTE_COMMAND_START, 1, 0, &ack);
    int32_t codes[6] = {0, 1024, 2048, 3072, 4095, 2049};
    /* the host does not read: the ring fills, later scans are dropped and counted */
    const unsigned total = FORTE_RING_CAPACITY + 100u;
    for (unsigned i = 0; i < total; ++i) {
        forte_device_on_tick(&device, 500u * (uint64_t)i, codes, 0);
    }
    CHECK_EQ_INT(atomic_load(&device.overruns), 100);
    /* the host catches up; the scan after the overruns carries the flag and the count */
    forte_sample_t sample;
    unsigned popped = 0;
    bool sequences_ok = true;
    while (forte_ring_pop(&device.ring, &sample)) {
        sequences_ok = sequences_ok && sample.sequence == popped;
        if (popped == 0) {
            CHECK_EQ_INT(sample.flags & FORTE_FLAG_SESSION_START, FORTE_FLAG_SESSION_START);
            CHECK_EQ_INT(sample.values[0], -1024);
            CHECK_EQ_INT(sample.values[1], -512);
            CHECK_EQ_INT(sample.values[2], 0);
            CHECK_EQ_INT(sample.values[3], 512);
            CHECK_EQ_INT(sample.values[4], 1024);
            CHECK_EQ_INT(sample.values[5], 1);
        }
        popped++;
    }
    CHECK(sequences_ok);
    CHECK_EQ_INT(popped, FORTE_RING_CAPACITY);
    forte_device_on_tick(&device, 500u * (uint64_t)total, codes, 0);
    CHECK(forte_ring_pop(&device.ring, &sample));
    CHECK_EQ_INT(sample.sequence, total); /* gap of 100 sequence numbers */
    CHECK_EQ_INT(sample.overruns, 100);
    CHECK_EQ_INT(sample.flags & FORTE_FLAG_OVERRUN, FORTE_FLAG_OVERRUN);
    CHECK_EQ_INT(sample.flags & FORTE_FLAG_SESSION_START, 0);
    /* missed timer instants are overruns too, and skip sequence numbers */
    forte_device_on_tick(&device, 500u * (uint64_t)(total + 3), codes, 2);
    CHECK(forte_ring_pop(&device.ring, &sample));
    CHECK_EQ_INT(sample.sequence, total + 3);
    CHECK_EQ_INT(sample.overruns, 102);
    /* saturation: codes beyond the calibrated span are clipped and flagged per channel */
    device.calibration[2].half_span_code = 1000;
    codes[2] = 3500;
    forte_device_on_tick(&device, 500u * (uint64_t)(total + 4), codes, 0);
    CHECK(forte_ring_pop(&device.ring, &sample));
    CHECK_EQ_INT(sample.values[2], 1024);
    CHECK_EQ_INT(sample.saturated, 1u << 2);
    CHECK_EQ_INT(sample.flags & FORTE_FLAG_SATURATED, FORTE_FLAG_SATURATED);
    CHECK_EQ_INT(sample.flags & FORTE_FLAG_OVERRUN, 0);
    /* a new START resets sequence and overrun count */
    send_command(&device, FORTE_COMMAND_STOP, 2, 0, &ack);
    send_command(&device, FORTE_COMMAND_START, 3, 0, &ack);
    forte_device_on_tick(&device, 10u, codes, 0);
    CHECK(forte_ring_pop(&device.ring, &sample));
    CHECK_EQ_INT(sample.sequence, 0);
    CHECK_EQ_INT(sample.overruns, 0);
}

static void test_tx_staging_partial_writes(void)
{
    static forte_tx_t tx;
    forte_tx_init(&tx);
    uint8_t frame[FORTE_SAMPLE_FRAME_SIZE];
    memset(frame, 0x33, sizeof(frame));
    unsigned staged = 0;
    while (forte_tx_stage(&tx, frame, sizeof(frame))) {
        staged++;
    }
    CHECK_EQ_INT(staged, FORTE_TX_CAPACITY / FORTE_SAMPLE_FRAME_SIZE);
    const uint8_t *data = NULL;
    CHECK_EQ_INT(forte_tx_pending(&tx, &data), staged * FORTE_SAMPLE_FRAME_SIZE);
    forte_tx_consumed(&tx, 10); /* the USB driver took only 10 bytes */
    const size_t full = staged * FORTE_SAMPLE_FRAME_SIZE;
    CHECK_EQ_INT(forte_tx_pending(&tx, &data), full - 10);
    CHECK_EQ_INT(data[0], 0x33);
    CHECK_EQ_INT(forte_tx_space(&tx), FORTE_TX_CAPACITY - (full - 10)); /* compacted */
    CHECK(!forte_tx_stage(&tx, frame, sizeof(frame)));                 /* whole frames only */
    CHECK(forte_tx_stage(&tx, frame, 10));
    CHECK_EQ_INT(forte_tx_pending(&tx, &data), full);
    forte_tx_consumed(&tx, 100000); /* clamps to what is pending */
    CHECK_EQ_INT(forte_tx_pending(&tx, &data), 0);
    CHECK_EQ_INT(forte_tx_space(&tx), FORTE_TX_CAPACITY);
}

/* Device -> bytes with random USB write sizes -> decoder: every staged sample arrives. */
static void test_end_to_end_device_to_decoder(void)
{
    static forte_device_t device;
    static forte_tx_t tx;
    forte_device_init(&device);
    forte_tx_init(&tx);
    forte_decoder_t decoder;
    forte_decoder_init(&decoder);

    /* host sends commands as bytes; the device decodes them and answers */
    uint8_t command_bytes[64];
    const forte_command_t set_rate = {FORTE_COMMAND_SET_RATE, 11, 4000};
    const forte_command_t start = {FORTE_COMMAND_START, 12, 0};
    size_t n = forte_encode_command(&set_rate, command_bytes, sizeof(command_bytes));
    n += forte_encode_command(&start, command_bytes + n, sizeof(command_bytes) - n);
    forte_decoder_t device_decoder;
    forte_decoder_init(&device_decoder);
    size_t offset = 0;
    forte_frame_t frame;
    size_t consumed = 0;
    unsigned acks = 0;
    while (forte_decoder_feed(&device_decoder, command_bytes + offset, n - offset, &frame,
                              &consumed)) {
        offset += consumed;
        CHECK_EQ_INT(frame.type, FORTE_TYPE_COMMAND);
        forte_ack_t ack;
        forte_device_handle_command(&device, &frame.body.command, &ack);
        uint8_t ack_bytes[32];
        const size_t ack_length = forte_encode_ack(&ack, ack_bytes, sizeof(ack_bytes));
        CHECK(forte_tx_stage(&tx, ack_bytes, ack_length));
        acks++;
    }
    CHECK_EQ_INT(acks, 2);
    CHECK_EQ_INT(device.period_us, 250);

    forte_schedule_t schedule;
    forte_schedule_start(&schedule, 5000, device.period_us);
    unsigned seed = 12345u;
    unsigned samples_received = 0;
    unsigned acks_received = 0;
    bool samples_ok = true;
    uint8_t wire[FORTE_TX_CAPACITY];
    for (unsigned tick = 0; tick < 20000; ++tick) {
        uint64_t scan_time = 0;
        const uint32_t missed = forte_schedule_advance(&schedule, schedule.next_alarm_us + 3u, &scan_time);
        int32_t codes[6];
        for (int k = 0; k < 6; ++k) {
            codes[k] = (int32_t)((tick * 37u + (unsigned)k * 401u) % 4096u);
        }
        forte_device_on_tick(&device, scan_time, codes, missed);
        forte_device_stage_samples(&device, &tx);
        /* the USB driver accepts a random number of bytes */
        seed = seed * 1103515245u + 12345u;
        const size_t accept = (seed >> 16) % 200u;
        const uint8_t *pending = NULL;
        size_t length = forte_tx_pending(&tx, &pending);
        if (length > accept) {
            length = accept;
        }
        memcpy(wire, pending, length);
        forte_tx_consumed(&tx, length);
        size_t used = 0;
        while (forte_decoder_feed(&decoder, wire + used, length - used, &frame, &consumed)) {
            used += consumed;
            if (frame.type == FORTE_TYPE_ACK) {
                acks_received++;
                continue;
            }
            const forte_sample_t *s = &frame.body.sample;
            samples_ok = samples_ok && s->sequence == samples_received &&
                         s->time_us == 5000u + 250u * (uint64_t)samples_received;
            for (int k = 0; k < 6; ++k) {
                const forte_calibration_t identity = {2048, 2048};
                const int32_t code = (int32_t)((s->sequence * 37u + (unsigned)k * 401u) % 4096u);
                samples_ok = samples_ok && s->values[k] == forte_normalise_code(code, &identity, NULL);
            }
            samples_received++;
        }
    }
    CHECK(samples_ok);
    CHECK_EQ_INT(acks_received, 2);
    CHECK_EQ_INT(atomic_load(&device.overruns), 0);
    CHECK_EQ_INT(decoder.corrupt_frames, 0);
    CHECK_EQ_INT(decoder.discarded_bytes, 0);
    /* samples still in the ring or staging are the only ones not yet received */
    const uint8_t *pending = NULL;
    const size_t still_staged = forte_tx_pending(&tx, &pending) + decoder.fill;
    CHECK_EQ_INT(samples_received + forte_ring_count(&device.ring) +
                     still_staged / FORTE_SAMPLE_FRAME_SIZE,
                 20000);
}

int main(int argc, char **argv)
{
    if (argc > 1) {
        vector_folder = argv[1];
    }
    RUN_TEST(test_crc_vectors);
    RUN_TEST(test_decoder_vectors);
    RUN_TEST(test_normalise_vectors);
    RUN_TEST(test_normalise_is_monotonic_and_symmetric);
    RUN_TEST(test_ring_order_full_and_wrap);
    RUN_TEST(test_rate_validation);
    RUN_TEST(test_schedule_exact_and_missed);
    RUN_TEST(test_device_commands);
    RUN_TEST(test_device_overruns_are_counted_and_never_block);
    RUN_TEST(test_tx_staging_partial_writes);
    RUN_TEST(test_end_to_end_device_to_decoder);
    printf("forte firmware core: %u passed, %u failed\n", harness_passed, harness_failed);
    return harness_failed == 0 ? 0 : 1;
}
