/**
 * @file forte_device.h
 * @brief Board-independent device logic: ADC normalisation, the sample ring between the
 *        sampling interrupt and the USB writer, scan scheduling (rate bookkeeping), the
 *        command handler and the transmit staging buffer.
 *
 * Threading model (as used by firmware/esp32s3): forte_device_on_tick() runs in the
 * sampling interrupt (the only producer of the ring); everything else runs in one task
 * (the only consumer). The ring is lock-free single-producer/single-consumer.
 */
#ifndef FORTE_DEVICE_H
#define FORTE_DEVICE_H

#include <stdatomic.h>
#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#include "forte_protocol.h"

#ifdef __cplusplus
extern "C" {
#endif

/* ---- normalisation --------------------------------------------------------------- */

/** Per-channel calibration of the raw ADC code (0..4095 for 12 bits). */
typedef struct {
    int32_t zero_code;      /**< ADC code at 0 inH2O (differential zero) */
    int32_t half_span_code; /**< ADC codes from zero to +1 inH2O (> 0) */
} forte_calibration_t;

/**
 * Map a raw ADC code to the protocol scale: round((code - zero) * 1024 / half_span),
 * ties away from zero, clipped to [-1024, +1024].
 *
 * @param code        raw ADC code
 * @param calibration channel calibration (half_span_code > 0)
 * @param clipped     set to true if the result was clipped (may be NULL)
 * @return reading in counts (1024 = +1.0 = +1 inH2O)
 */
int16_t forte_normalise_code(int32_t code, const forte_calibration_t *calibration, bool *clipped);

/* ---- sample ring (SPSC) ------------------------------------------------------------ */

/** Ring capacity [samples], a power of two (256 ms at 2 kHz). */
#define FORTE_RING_CAPACITY 512u

typedef struct {
    forte_sample_t slots[FORTE_RING_CAPACITY];
    atomic_uint head; /**< next slot to write (producer only) */
    atomic_uint tail; /**< next slot to read (consumer only) */
} forte_ring_t;

void forte_ring_init(forte_ring_t *ring);
/** Producer: store a copy of @p sample; false (nothing stored) if the ring is full. */
bool forte_ring_push(forte_ring_t *ring, const forte_sample_t *sample);
/** Consumer: take the oldest sample; false if empty. */
bool forte_ring_pop(forte_ring_t *ring, forte_sample_t *sample);
/** Number of samples stored (approximate while the producer runs). */
unsigned forte_ring_count(forte_ring_t *ring);

/* ---- rate bookkeeping --------------------------------------------------------------- */

#define FORTE_RATE_MIN_HZ 1u
#define FORTE_RATE_MAX_HZ 4000u
#define FORTE_RATE_DEFAULT_HZ 2000u

/**
 * Check a scan rate: allowed are FORTE_RATE_MIN_HZ..FORTE_RATE_MAX_HZ dividing 1 000 000
 * exactly, so the period is a whole number of microseconds and the rate is exact.
 *
 * @param rate_hz   requested rate [Hz]
 * @param period_us receives the period [us] when valid (may be NULL)
 * @return true if valid
 */
bool forte_rate_valid(uint32_t rate_hz, uint32_t *period_us);

/**
 * Scan scheduler of the timer interrupt. The alarm of the next scan is always the
 * previous alarm plus one period (never "now + period"), so the rate does not drift with
 * interrupt latency. If the interrupt ran so late that later scan instants already
 * passed, those scans are missed: they are counted, their sequence numbers are skipped
 * and the next alarm is the first scan instant still in the future.
 */
typedef struct {
    uint64_t next_alarm_us; /**< time of the next scan [us] */
    uint32_t period_us;     /**< scan period [us] */
} forte_schedule_t;

void forte_schedule_start(forte_schedule_t *schedule, uint64_t first_alarm_us, uint32_t period_us);
/**
 * Called by the timer interrupt at device time @p now_us (>= next_alarm_us). The scan
 * taken now belongs to the latest scan instant <= now_us; the earlier instants since the
 * last scan are missed.
 *
 * @param schedule     scheduler state; next_alarm_us is advanced past now_us
 * @param now_us       device time of the interrupt [us]
 * @param scan_time_us receives the scan instant of this scan [us]
 * @return number of scan instants missed before this one (0 normally)
 */
uint32_t forte_schedule_advance(forte_schedule_t *schedule, uint64_t now_us,
                                uint64_t *scan_time_us);

/* ---- device state ------------------------------------------------------------------ */

/** What the board layer must do after a command. */
typedef enum {
    FORTE_ACTION_NONE = 0,
    FORTE_ACTION_START_SAMPLING = 1, /**< start the scan timer at device->period_us */
    FORTE_ACTION_STOP_SAMPLING = 2,  /**< stop the scan timer */
    FORTE_ACTION_SEND_INFO = 3,      /**< send an INFO frame after the ACK */
} forte_action_t;

typedef struct {
    forte_ring_t ring;
    forte_calibration_t calibration[FORTE_CHANNEL_COUNT];
    volatile bool streaming;
    uint32_t rate_hz;
    uint32_t period_us;
    /* producer (interrupt) side */
    uint32_t next_sequence;    /**< sequence of the next scan */
    atomic_uint overruns;      /**< samples dropped since START (ring full or missed scans) */
    uint32_t overruns_reported; /**< overruns value put into the last stored sample */
    bool session_start;        /**< next stored sample is the first of the session */
    /* consumer side */
    uint32_t samples_sent;
} forte_device_t;

/** Initialise with default rate and identity calibration (zero 2048, half span 2048). */
void forte_device_init(forte_device_t *device);

/**
 * Interrupt side: one scan of @p codes (raw ADC codes, channel order of the contract)
 * taken at device time @p time_us. Normalises, stamps and stores it; if the ring is full
 * the scan is dropped and counted as an overrun (its sequence number is still used, so
 * the host sees the gap). Never blocks.
 *
 * @param missed scans missed before this one (from forte_schedule_advance), counted as
 *               overruns and skipped in the sequence
 */
void forte_device_on_tick(forte_device_t *device, uint64_t time_us,
                          const int32_t codes[FORTE_CHANNEL_COUNT], uint32_t missed);

/**
 * Task side: execute one host command and fill its acknowledgement.
 *
 * @return the action the board layer must take
 */
forte_action_t forte_device_handle_command(forte_device_t *device, const forte_command_t *command,
                                           forte_ack_t *ack);

/** Fill the identification frame body. */
void forte_device_info(const forte_device_t *device, uint64_t device_id, forte_info_t *info);

/* ---- transmit staging ----------------------------------------------------------------- */

/** Frames waiting for the USB writer; whole frames go in, any number of bytes come out. */
#define FORTE_TX_CAPACITY 1024u

typedef struct {
    uint8_t bytes[FORTE_TX_CAPACITY];
    size_t length;  /**< bytes staged */
    size_t written; /**< bytes of the staged data already handed to the USB driver */
} forte_tx_t;

void forte_tx_init(forte_tx_t *tx);
/** Free space [bytes] (after compacting already written bytes). */
size_t forte_tx_space(forte_tx_t *tx);
/** Stage a complete frame; false (nothing staged) if it does not fit. */
bool forte_tx_stage(forte_tx_t *tx, const uint8_t *frame, size_t length);
/** Bytes not yet written: *data and return value; then call forte_tx_consumed(). */
size_t forte_tx_pending(const forte_tx_t *tx, const uint8_t **data);
void forte_tx_consumed(forte_tx_t *tx, size_t count);

/**
 * Move samples from the ring into the staging buffer as whole frames while both have
 * room. Samples stay in the ring (the ring absorbs host slowness; the interrupt counts
 * the overruns when it fills).
 *
 * @return number of sample frames staged
 */
unsigned forte_device_stage_samples(forte_device_t *device, forte_tx_t *tx);

#ifdef __cplusplus
}
#endif

#endif /* FORTE_DEVICE_H */
