/*
 * exo_link: the board's side of the exodigit glove link, protocol version 1, in portable C99
 * (docs/spec/hardware.md): CRC-16/CCITT-FALSE, COBS framing, the handshake, the watchdog, the
 * openings and the samples. No allocation, no I/O, no clock of its own: the firmware feeds it
 * received bytes and the time (microseconds, wrapping u32) and writes out the frames it gives.
 *
 * The same state machine as exodigit_nodes/hardware/board.py; the suite builds this file on
 * the host and checks that both give the same bytes for the same input
 * (tests/test_hardware_firmware.py).
 */
#ifndef EXO_LINK_H
#define EXO_LINK_H

#include <stdbool.h>
#include <stddef.h>
#include <stdint.h>

#ifdef __cplusplus
extern "C" {
#endif

#define EXO_PROTOCOL_VERSION 1
#define EXO_CHAMBERS 3
#define EXO_VALVES (2 * EXO_CHAMBERS) /* inlets MCP, PIP, DIP, then outlets */
#define EXO_DUTY_FULL 10000u          /* an opening of 1 */
#define EXO_MAX_PAYLOAD 64            /* type byte and body */
#define EXO_MAX_STUFFED (EXO_MAX_PAYLOAD + 2 + 1) /* payload, CRC, one COBS code byte */
#define EXO_MAX_FRAME (EXO_MAX_STUFFED + 1)       /* and the zero delimiter */

enum exo_type {
    EXO_HELLO = 0x01,
    EXO_OPENINGS = 0x02,
    EXO_HEARTBEAT = 0x03,
    EXO_CAPABILITIES = 0x81,
    EXO_SAMPLE = 0x82,
    EXO_NOTICE = 0x83
};

enum exo_status {
    EXO_WATCHDOG_VENT = 0x0001,
    EXO_OVER_PRESSURE = 0x0002,
    EXO_SUPPLY_LOW = 0x0004,
    EXO_SENSOR_FAULT = 0x0008,
    EXO_COMMAND_REFUSED = 0x0010,
    EXO_RECEIVE_ERRORS = 0x0020
};

enum exo_notice {
    EXO_BAD_OPENINGS = 1,
    EXO_UNKNOWN_TYPE = 2,
    EXO_BAD_LENGTH = 3,
    EXO_NOT_STREAMING = 4
};

/* What the board answers to every HELLO (docs/spec/hardware.md, CAPABILITIES). */
typedef struct {
    uint8_t version;
    uint8_t firmware[3];
    uint8_t chambers;
    uint8_t bend_sensors;
    uint16_t sample_rate_hz;
    uint16_t watchdog_ms;
    uint16_t pressure_quantum_pa;
    int32_t pressure_min_pa;
    int32_t pressure_max_pa;
    int32_t vent_pressure_pa;
    uint16_t angle_quantum; /* 1/10,000 rad */
    uint8_t proportional_valves;
    uint16_t pwm_hz;
} exo_capabilities;

/* One board's protocol state. Initialise with exo_board_init; the fields are read-only. */
typedef struct {
    exo_capabilities capabilities;
    uint8_t received[EXO_MAX_STUFFED];
    size_t received_length;
    bool overlong;
    bool streaming;
    bool tripped;
    bool refused;
    bool receive_errors;
    bool over_pressure[EXO_CHAMBERS];
    uint16_t commanded[EXO_VALVES];
    uint16_t applied_sequence;
    uint16_t sequence;
    uint32_t last_valid_us;
} exo_board;

/* CRC-16/CCITT-FALSE (poly 0x1021, init 0xFFFF, not reflected, no final XOR). */
uint16_t exo_crc16(const uint8_t *data, size_t length);

/* COBS of `length` bytes into `out` (room for length + length / 254 + 1); its length. */
size_t exo_cobs_encode(const uint8_t *data, size_t length, uint8_t *out);

/* Unstuff `length` bytes (no zero among them) into `out` (room for `length`); its length, or
 * (size_t)-1 if they are no valid COBS. */
size_t exo_cobs_decode(const uint8_t *data, size_t length, uint8_t *out);

/* The whole frame of a payload (1 to EXO_MAX_PAYLOAD bytes) into `out` (EXO_MAX_FRAME bytes):
 * COBS(payload, CRC low, CRC high), then 0; its length, 0 for a payload of a wrong size. */
size_t exo_frame(const uint8_t *payload, size_t length, uint8_t *out);

/* Silent and vented, until a HELLO of capabilities->version. */
void exo_board_init(exo_board *board, const exo_capabilities *capabilities);

/* Take one received byte at `now_us`. When it ends a frame that needs an answer
 * (CAPABILITIES or a NOTICE), the answer's frame is written to `answer` (EXO_MAX_FRAME bytes)
 * and its length returned; else 0. */
size_t exo_board_receive(exo_board *board, uint8_t byte, uint32_t now_us, uint8_t *answer);

/* The duties (0..EXO_DUTY_FULL) the valves get at `now_us`: the host's openings, or a vent
 * before a HELLO, after the watchdog time without a valid frame (until the next OPENINGS), and
 * for a chamber at or above the vent pressure. */
void exo_board_duties(exo_board *board, uint32_t now_us, uint16_t duties[EXO_VALVES]);

/* The frame of a sample read at `now_us` into `out` (EXO_MAX_FRAME bytes); its length, 0
 * before a HELLO. `angles` (1/10,000 rad) is used when the board has bend sensors; `flags`
 * adds EXO_SUPPLY_LOW or EXO_SENSOR_FAULT. Also takes `pressures_pa` for the vent pressure. */
size_t exo_board_sample(exo_board *board, uint32_t now_us, const int32_t pressures_pa[EXO_CHAMBERS],
                        const int16_t *angles, uint16_t flags, uint8_t *out);

#ifdef __cplusplus
}
#endif

#endif
