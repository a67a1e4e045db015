/**
 * @file main.c
 * @brief ESP32-S3 board layer of the FORTE sensor firmware (ESP-IDF >= 5.2).
 *
 * Everything protocol- or state-related lives in the portable core (../../core), which is
 * unit-tested on the host. This file only connects it to the hardware:
 *
 *  - Sampling: a general-purpose timer counts microseconds since boot (1 MHz, never
 *    reloaded: its count is the device clock). Its alarm interrupt, on core 1, fires at
 *    exactly every period (next alarm = previous alarm + period, from the core's
 *    scheduler, so interrupt latency never accumulates) and converts the six channels
 *    back to back with adc_oneshot_read_isr() (the channels of one scan are taken within
 *    about 6 x 14 us). The scan is normalised and pushed into the lock-free ring. If the
 *    ring is full (host too slow) the scan is dropped and counted; sampling never waits.
 *  - I/O task, core 0: decodes host commands from USB, executes them through the core,
 *    stages acknowledgements first and then sample frames, and hands bytes to the
 *    USB-Serial-JTAG driver without blocking (partial writes stay staged).
 */
#include <stdbool.h>
#include <stdint.h>
#include <string.h>

#include "board_config.h"
#include "driver/gptimer.h"
#include "driver/usb_serial_jtag.h"
#include "esp_adc/adc_oneshot.h"
#include "esp_attr.h"
#include "esp_check.h"
#include "esp_log.h"
#include "esp_mac.h"
#include "forte_device.h"
#include "forte_protocol.h"
#include "freertos/FreeRTOS.h"
#include "freertos/task.h"

static const char *TAG = "forte";

static forte_device_t device;          /* core state: ring, calibration, session */
static forte_schedule_t schedule;      /* alarm bookkeeping, owned by the interrupt */
static forte_tx_t tx;                  /* staged bytes for USB, owned by the I/O task */
static gptimer_handle_t timer;
static adc_oneshot_unit_handle_t adc;
static TaskHandle_t io_task;
static volatile uint32_t adc_failures; /* scans lost to ADC read errors (also overruns) */

/* ---- sampling interrupt (core 1) ------------------------------------------------------ */

static bool IRAM_ATTR on_alarm(gptimer_handle_t handle, const gptimer_alarm_event_data_t *event,
                               void *context)
{
    (void)context;
    if (!device.streaming) {
        return false; /* STOP: do not re-arm */
    }
    uint64_t scan_time_us = 0;
    uint32_t missed = forte_schedule_advance(&schedule, event->count_value, &scan_time_us);
    int32_t codes[FORTE_CHANNEL_COUNT];
    bool ok = true;
    for (int k = 0; k < FORTE_CHANNEL_COUNT; ++k) {
        int raw = 0;
        ok = ok && adc_oneshot_read_isr(adc, forte_adc_channels[k], &raw) == ESP_OK;
        codes[k] = raw;
    }
    if (ok) {
        forte_device_on_tick(&device, scan_time_us, codes, missed);
    } else {
        /* never invent a reading: the scan is lost, its sequence number skipped */
        adc_failures++;
        atomic_fetch_add(&device.overruns, 1u + missed);
        device.next_sequence += 1u + missed;
    }
    const gptimer_alarm_config_t alarm = {
        .alarm_count = schedule.next_alarm_us,
        .flags.auto_reload_on_alarm = false,
    };
    gptimer_set_alarm_action(handle, &alarm);
    BaseType_t woken = pdFALSE;
    vTaskNotifyGiveFromISR(io_task, &woken);
    return woken == pdTRUE;
}

static void start_sampling(void)
{
    uint64_t now_us = 0;
    ESP_ERROR_CHECK(gptimer_get_raw_count(timer, &now_us));
    /* first scan on the next whole period, so device timestamps are multiples of it */
    const uint64_t first = (now_us / device.period_us + 2u) * device.period_us;
    forte_schedule_start(&schedule, first, device.period_us);
    const gptimer_alarm_config_t alarm = {
        .alarm_count = first,
        .flags.auto_reload_on_alarm = false,
    };
    ESP_ERROR_CHECK(gptimer_set_alarm_action(timer, &alarm));
}

static void stop_sampling(void)
{
    /* device.streaming is already false: an alarm in flight will not re-arm */
    ESP_ERROR_CHECK(gptimer_set_alarm_action(timer, NULL));
}

/* Runs on the sampling core so that the timer interrupt is allocated there. */
static void sampling_setup_task(void *argument)
{
    const gptimer_config_t config = {
        .clk_src = GPTIMER_CLK_SRC_DEFAULT,
        .direction = GPTIMER_COUNT_UP,
        .resolution_hz = 1000000, /* 1 tick = 1 us: the device clock */
    };
    ESP_ERROR_CHECK(gptimer_new_timer(&config, &timer));
    const gptimer_event_callbacks_t callbacks = {.on_alarm = on_alarm};
    ESP_ERROR_CHECK(gptimer_register_event_callbacks(timer, &callbacks, NULL));
    ESP_ERROR_CHECK(gptimer_enable(timer));
    ESP_ERROR_CHECK(gptimer_start(timer)); /* runs forever; alarms only while streaming */
    xTaskNotifyGive((TaskHandle_t)argument);
    vTaskDelete(NULL);
}

/* ---- I/O task (core 0) ---------------------------------------------------------------- */

static uint64_t device_id(void)
{
    uint8_t mac[6] = {0};
    esp_efuse_mac_get_default(mac);
    uint64_t id = 0;
    for (int i = 0; i < 6; ++i) {
        id = (id << 8) | mac[i];
    }
    return id;
}

/* One USB read holds at most 64 / 11 = 5 commands; each needs at most an ACK and an INFO. */
#define COMMAND_READ_SIZE 64u
#define CONTROL_CAPACITY                                                                      \
    ((COMMAND_READ_SIZE / FORTE_FRAME_SIZE(FORTE_COMMAND_PAYLOAD_SIZE) + 1u) *               \
     (FORTE_FRAME_SIZE(FORTE_ACK_PAYLOAD_SIZE) + FORTE_FRAME_SIZE(FORTE_INFO_PAYLOAD_SIZE)))

static void io_task_main(void *argument)
{
    (void)argument;
    static forte_decoder_t commands;
    static uint8_t control[CONTROL_CAPACITY];
    size_t control_length = 0; /* acks (+ info) waiting for room in the staging buffer */
    forte_decoder_init(&commands);
    const uint64_t id = device_id();
    for (;;) {
        /* woken by every scan, or at least every millisecond for commands */
        ulTaskNotifyTake(pdTRUE, pdMS_TO_TICKS(1));

        /* read commands only when the previous answers are staged, so they always fit */
        if (control_length == 0) {
            uint8_t input[COMMAND_READ_SIZE];
            const int received = usb_serial_jtag_read_bytes(input, sizeof(input), 0);
            size_t offset = 0;
            forte_frame_t frame;
            size_t used = 0;
            while (received > 0 &&
                   forte_decoder_feed(&commands, input + offset, (size_t)received - offset, &frame,
                                      &used)) {
                offset += used;
                if (frame.type != FORTE_TYPE_COMMAND) {
                    continue;
                }
                forte_ack_t ack;
                const forte_action_t action =
                    forte_device_handle_command(&device, &frame.body.command, &ack);
                if (action == FORTE_ACTION_START_SAMPLING) {
                    /* staged frames of an earlier session still go out whole, before the
                     * ACK; the host starts the new session at the ACK */
                    start_sampling();
                } else if (action == FORTE_ACTION_STOP_SAMPLING) {
                    stop_sampling();
                }
                control_length += forte_encode_ack(&ack, control + control_length,
                                                   sizeof(control) - control_length);
                if (action == FORTE_ACTION_SEND_INFO) {
                    forte_info_t info;
                    forte_device_info(&device, id, &info);
                    control_length += forte_encode_info(&info, control + control_length,
                                                        sizeof(control) - control_length);
                }
            }
        }
        /* acknowledgements go out before any further sample */
        if (control_length > 0 && forte_tx_stage(&tx, control, control_length)) {
            control_length = 0;
        }
        if (control_length == 0) {
            forte_device_stage_samples(&device, &tx);
        }
        const uint8_t *pending = NULL;
        const size_t length = forte_tx_pending(&tx, &pending);
        if (length > 0) {
            const int written = usb_serial_jtag_write_bytes(pending, length, 0);
            if (written > 0) {
                forte_tx_consumed(&tx, (size_t)written);
            }
        }
    }
}

/* ---- start-up ---------------------------------------------------------------------- */

void app_main(void)
{
    forte_device_init(&device);
    for (int k = 0; k < FORTE_CHANNEL_COUNT; ++k) {
        device.calibration[k].zero_code = forte_calibration[k].zero_code;
        device.calibration[k].half_span_code = forte_calibration[k].half_span_code;
    }
    forte_tx_init(&tx);

    const adc_oneshot_unit_init_cfg_t unit = {.unit_id = FORTE_ADC_UNIT};
    ESP_ERROR_CHECK(adc_oneshot_new_unit(&unit, &adc));
    const adc_oneshot_chan_cfg_t channel = {
        .atten = FORTE_ADC_ATTENUATION,
        .bitwidth = FORTE_ADC_BITWIDTH,
    };
    for (int k = 0; k < FORTE_CHANNEL_COUNT; ++k) {
        ESP_ERROR_CHECK(adc_oneshot_config_channel(adc, forte_adc_channels[k], &channel));
    }

    usb_serial_jtag_driver_config_t usb = {
        .tx_buffer_size = FORTE_USB_TX_BUFFER,
        .rx_buffer_size = FORTE_USB_RX_BUFFER,
    };
    ESP_ERROR_CHECK(usb_serial_jtag_driver_install(&usb));

    xTaskCreatePinnedToCore(io_task_main, "forte_io", 4096, NULL, FORTE_IO_TASK_PRIORITY,
                            &io_task, FORTE_IO_CORE);
    xTaskCreatePinnedToCore(sampling_setup_task, "forte_timer", 3072,
                            xTaskGetCurrentTaskHandle(), configMAX_PRIORITIES - 1, NULL,
                            FORTE_SAMPLING_CORE);
    ulTaskNotifyTake(pdTRUE, portMAX_DELAY);
    ESP_LOGW(TAG, "FORTE sensor ready: protocol v%d, %u Hz default, waiting for START",
             FORTE_PROTOCOL_VERSION, (unsigned)device.rate_hz);
}
