/**
 * @file forte_protocol.h
 * @brief FORTE serial protocol, version 1: frame layout, encoders and a streaming decoder.
 *
 * Every frame (both directions) is
 *
 *     offset  size  field
 *     0       1     sync 0xA5
 *     1       1     sync 0x5A
 *     2       1     protocol version (1)
 *     3       1     frame type (forte_frame_type_t)
 *     4       1     payload length N (fixed per type, checked)
 *     5       N     payload, little-endian fields
 *     5+N     2     CRC-16/CCITT-FALSE over bytes 2 .. 4+N (version, type, length,
 *                   payload), little-endian
 *
 * The three bytes A5 5A 01 form the frame signature the decoder hunts for. See
 * docs/firmware.md for the payload layouts, units and the decoder's counting rules.
 */
#ifndef FORTE_PROTOCOL_H
#define FORTE_PROTOCOL_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define FORTE_SYNC0 0xA5u
#define FORTE_SYNC1 0x5Au
#define FORTE_PROTOCOL_VERSION 1u
#define FORTE_CHANNEL_COUNT 6
#define FORTE_HEADER_SIZE 5u
#define FORTE_CRC_SIZE 2u

/** Reading scale: 1024 counts = 1.0 = +1 inH2O (full scale of the ELVR-L01D). */
#define FORTE_COUNTS_PER_FULL_SCALE 1024

/** Frame types. */
typedef enum {
    FORTE_TYPE_SAMPLE = 0x01,  /**< device -> host: one 6-channel scan */
    FORTE_TYPE_COMMAND = 0x02, /**< host -> device: start, stop, identify, set rate */
    FORTE_TYPE_ACK = 0x03,     /**< device -> host: acknowledgement of one command */
    FORTE_TYPE_INFO = 0x04,    /**< device -> host: identification, after ACK of IDENTIFY */
} forte_frame_type_t;

/** Payload sizes [bytes], fixed per type. */
#define FORTE_SAMPLE_PAYLOAD_SIZE 28u
#define FORTE_COMMAND_PAYLOAD_SIZE 4u
#define FORTE_ACK_PAYLOAD_SIZE 8u
#define FORTE_INFO_PAYLOAD_SIZE 20u
#define FORTE_MAX_PAYLOAD_SIZE FORTE_SAMPLE_PAYLOAD_SIZE
#define FORTE_FRAME_SIZE(payload) (FORTE_HEADER_SIZE + (payload) + FORTE_CRC_SIZE)
#define FORTE_SAMPLE_FRAME_SIZE FORTE_FRAME_SIZE(FORTE_SAMPLE_PAYLOAD_SIZE)
#define FORTE_MAX_FRAME_SIZE FORTE_FRAME_SIZE(FORTE_MAX_PAYLOAD_SIZE)

/** Sample flags (forte_sample_t.flags). */
#define FORTE_FLAG_SATURATED 0x01u     /**< at least one channel clipped to +-1 */
#define FORTE_FLAG_OVERRUN 0x02u       /**< the device dropped samples just before this one */
#define FORTE_FLAG_SESSION_START 0x04u /**< first sample after START */

/** Command codes. */
typedef enum {
    FORTE_COMMAND_START = 0x01,    /**< start streaming; resets sequence and overrun count */
    FORTE_COMMAND_STOP = 0x02,     /**< stop streaming */
    FORTE_COMMAND_IDENTIFY = 0x03, /**< ACK followed by one INFO frame */
    FORTE_COMMAND_SET_RATE = 0x04, /**< argument = scan rate [Hz]; only while stopped */
} forte_command_code_t;

/** Acknowledgement status. */
typedef enum {
    FORTE_STATUS_OK = 0,
    FORTE_STATUS_UNKNOWN_COMMAND = 1,
    FORTE_STATUS_BAD_ARGUMENT = 2,
    FORTE_STATUS_BUSY = 3, /**< not allowed in the current state (e.g. SET_RATE while streaming) */
} forte_status_t;

/** One scan of the 6 channels. */
typedef struct {
    uint32_t sequence;   /**< scan index since START, wraps at 2^32 [count] */
    uint64_t time_us;    /**< device clock at the scheduled scan instant [us] */
    int16_t values[FORTE_CHANNEL_COUNT]; /**< readings, 1024 = +1.0 = +1 inH2O, clipped to +-1024 */
    uint16_t overruns;   /**< samples the device dropped since START, modulo 2^16 [count] */
    uint8_t flags;       /**< FORTE_FLAG_* */
    uint8_t saturated;   /**< bit k set = channel k clipped */
} forte_sample_t;

/** Host command. */
typedef struct {
    uint8_t command;   /**< forte_command_code_t */
    uint8_t token;     /**< chosen by the host, echoed in the ACK */
    uint16_t argument; /**< SET_RATE: rate [Hz]; otherwise 0 */
} forte_command_t;

/** Acknowledgement. */
typedef struct {
    uint8_t command; /**< command code acknowledged */
    uint8_t token;   /**< token of that command */
    uint8_t status;  /**< forte_status_t */
    uint8_t reserved;
    uint32_t value;  /**< START/SET_RATE/IDENTIFY: rate [Hz]; STOP: samples in the session */
} forte_ack_t;

/** Device identification. */
typedef struct {
    uint8_t protocol_version;
    uint8_t firmware_major;
    uint8_t firmware_minor;
    uint8_t firmware_patch;
    uint8_t channel_count;
    uint8_t adc_bits;                 /**< resolution of the raw ADC codes (12) */
    uint16_t counts_per_full_scale;   /**< 1024 */
    uint16_t rate_hz;                 /**< configured scan rate [Hz] */
    uint16_t ring_capacity;           /**< device sample buffer [samples] */
    uint64_t device_id;               /**< unique id (eFuse MAC on the ESP32-S3) */
} forte_info_t;

/** Any decoded frame. */
typedef struct {
    uint8_t type; /**< forte_frame_type_t */
    union {
        forte_sample_t sample;
        forte_command_t command;
        forte_ack_t ack;
        forte_info_t info;
    } body;
} forte_frame_t;

/** Payload length of a frame type, 0 for an unknown type. */
size_t forte_payload_size(uint8_t type);

/* Encoders: write one complete frame into out (capacity out_capacity) and return its
 * length in bytes, or 0 if it does not fit. */
size_t forte_encode_sample(const forte_sample_t *sample, uint8_t *out, size_t out_capacity);
size_t forte_encode_command(const forte_command_t *command, uint8_t *out, size_t out_capacity);
size_t forte_encode_ack(const forte_ack_t *ack, uint8_t *out, size_t out_capacity);
size_t forte_encode_info(const forte_info_t *info, uint8_t *out, size_t out_capacity);

/**
 * Streaming decoder. Bytes are classified exactly once: either part of a valid frame
 * or discarded. Counting rules:
 *  - a *candidate* starts wherever the signature A5 5A 01 appears;
 *  - a candidate whose type/length are invalid or whose CRC fails is a *corrupt frame*
 *    (corrupt_frames += 1); the decoder then resumes hunting at the candidate's second
 *    byte, so a good frame hidden inside the rejected bytes is still found;
 *  - every byte not part of a valid frame is counted in discarded_bytes.
 */
typedef struct {
    uint8_t buffer[FORTE_MAX_FRAME_SIZE];
    size_t fill;
    uint32_t frames;          /**< valid frames decoded */
    uint32_t corrupt_frames;  /**< rejected candidates (bad type/length or CRC) */
    uint32_t discarded_bytes; /**< bytes not part of a valid frame */
} forte_decoder_t;

/** Reset the decoder (drops a partial frame without counting it). */
void forte_decoder_init(forte_decoder_t *decoder);

/**
 * Feed bytes until one frame completes or the input is used up.
 *
 * @param decoder   decoder state
 * @param data      input bytes
 * @param length    number of input bytes
 * @param frame     receives the frame when one completes
 * @param consumed  receives how many input bytes were used (call again with the rest)
 * @return true if @p frame holds a new frame
 */
bool forte_decoder_feed(forte_decoder_t *decoder, const uint8_t *data, size_t length,
                        forte_frame_t *frame, size_t *consumed);

#ifdef __cplusplus
}
#endif

#endif /* FORTE_PROTOCOL_H */
