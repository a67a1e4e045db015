/**
 * @file board_config.h
 * @brief Wiring and calibration of the FORTE sensor board. Edit here, nowhere else.
 *
 * Channel order is the contract order (docs/contracts.md):
 *   0 left_distal, 1 left_middle, 2 left_root, 3 right_distal, 4 right_middle, 5 right_root.
 * All six inputs are on ADC1 (ADC2 is shared with the radio and not used).
 */
#ifndef FORTE_BOARD_CONFIG_H
#define FORTE_BOARD_CONFIG_H

#include "esp_adc/adc_oneshot.h"

/* ADC1 channel of each transducer output (ESP32-S3: ADC1_CHn is GPIO n+1). */
#define FORTE_ADC_UNIT ADC_UNIT_1
static const adc_channel_t forte_adc_channels[6] = {
    ADC_CHANNEL_0, /* GPIO1: left_distal   */
    ADC_CHANNEL_1, /* GPIO2: left_middle   */
    ADC_CHANNEL_2, /* GPIO3: left_root     */
    ADC_CHANNEL_3, /* GPIO4: right_distal  */
    ADC_CHANNEL_4, /* GPIO5: right_middle  */
    ADC_CHANNEL_5, /* GPIO6: right_root    */
};

/* 12 dB attenuation: about 0..3.1 V input range at 12-bit resolution. */
#define FORTE_ADC_ATTENUATION ADC_ATTEN_DB_12
#define FORTE_ADC_BITWIDTH ADC_BITWIDTH_12

/*
 * Calibration per channel: ADC code at 0 inH2O and ADC codes from there to +1 inH2O.
 * The defaults assume a ratiometric output centred in the ADC range spanning the full
 * range; measure each channel at bring-up (docs/firmware.md, "Calibrate") and enter the
 * numbers here. The host tares every grasp anyway; these only set the -1..1 scale.
 */
#define FORTE_CALIBRATION_DEFAULT {2048, 2048}
static const struct {
    int zero_code;
    int half_span_code;
} forte_calibration[6] = {
    FORTE_CALIBRATION_DEFAULT, FORTE_CALIBRATION_DEFAULT, FORTE_CALIBRATION_DEFAULT,
    FORTE_CALIBRATION_DEFAULT, FORTE_CALIBRATION_DEFAULT, FORTE_CALIBRATION_DEFAULT,
};

/* Cores: sampling interrupt on core 1 (nothing else runs there), USB/command task on 0. */
#define FORTE_SAMPLING_CORE 1
#define FORTE_IO_CORE 0
#define FORTE_IO_TASK_PRIORITY 10

/* USB-Serial-JTAG driver buffers [bytes]. */
#define FORTE_USB_TX_BUFFER 4096
#define FORTE_USB_RX_BUFFER 256

#endif /* FORTE_BOARD_CONFIG_H */
