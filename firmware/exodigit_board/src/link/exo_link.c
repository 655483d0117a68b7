/* exo_link: see exo_link.h and docs/spec/hardware.md. */
#include "exo_link.h"

#include <string.h>

#define CRC_BYTES 2
#define HELLO_BODY 1
#define OPENINGS_BODY 14
#define HEARTBEAT_BODY 0
#define CAPABILITIES_BODY 29
#define SAMPLE_BODY 22
#define ANGLES_BODY 6
#define NOTICE_BODY 2

uint16_t exo_crc16(const uint8_t *data, size_t length) {
    uint16_t crc = 0xFFFFu;
    for (size_t i = 0; i < length; i++) {
        crc ^= (uint16_t)((uint16_t)data[i] << 8);
        for (int bit = 0; bit < 8; bit++) {
            crc = (crc & 0x8000u) ? (uint16_t)((crc << 1) ^ 0x1021u) : (uint16_t)(crc << 1);
        }
    }
    return crc;
}

size_t exo_cobs_encode(const uint8_t *data, size_t length, uint8_t *out) {
    size_t code_at = 0, written = 1;
    uint8_t code = 1;
    for (size_t i = 0; i < length; i++) {
        if (data[i] == 0) {
            out[code_at] = code;
            code_at = written++;
            code = 1;
        } else {
            out[written++] = data[i];
            if (++code == 0xFF && i + 1 < length) { /* a full block: the next starts anew */
                out[code_at] = code;
                code_at = written++;
                code = 1;
            }
        }
    }
    out[code_at] = code;
    return written;
}

size_t exo_cobs_decode(const uint8_t *data, size_t length, uint8_t *out) {
    size_t read = 0, written = 0;
    while (read < length) {
        uint8_t code = data[read++];
        if (code == 0 || read + code - 1 > length) {
            return (size_t)-1;
        }
        for (uint8_t i = 1; i < code; i++) {
            out[written++] = data[read++];
        }
        if (code < 0xFF && read < length) {
            out[written++] = 0;
        }
    }
    return written;
}

size_t exo_frame(const uint8_t *payload, size_t length, uint8_t *out) {
    uint8_t checked[EXO_MAX_PAYLOAD + CRC_BYTES];
    if (length == 0 || length > EXO_MAX_PAYLOAD) {
        return 0;
    }
    memcpy(checked, payload, length);
    uint16_t crc = exo_crc16(payload, length);
    checked[length] = (uint8_t)(crc & 0xFF);
    checked[length + 1] = (uint8_t)(crc >> 8);
    size_t stuffed = exo_cobs_encode(checked, length + CRC_BYTES, out);
    out[stuffed] = 0;
    return stuffed + 1;
}

/* -- little-endian fields ---------------------------------------------------------------- */

static uint8_t *put16(uint8_t *at, uint16_t value) {
    at[0] = (uint8_t)(value & 0xFF);
    at[1] = (uint8_t)(value >> 8);
    return at + 2;
}

static uint8_t *put32(uint8_t *at, uint32_t value) {
    for (int i = 0; i < 4; i++) {
        at[i] = (uint8_t)((value >> (8 * i)) & 0xFF);
    }
    return at + 4;
}

static uint16_t get16(const uint8_t *at) {
    return (uint16_t)(at[0] | (uint16_t)at[1] << 8);
}

/* -- answers ----------------------------------------------------------------------------- */

static size_t capabilities_frame(const exo_capabilities *c, uint8_t *out) {
    uint8_t payload[1 + CAPABILITIES_BODY];
    uint8_t *at = payload;
    *at++ = EXO_CAPABILITIES;
    *at++ = c->version;
    for (int i = 0; i < 3; i++) {
        *at++ = c->firmware[i];
    }
    *at++ = c->chambers;
    *at++ = c->bend_sensors;
    at = put16(at, c->sample_rate_hz);
    at = put16(at, c->watchdog_ms);
    at = put16(at, c->pressure_quantum_pa);
    at = put32(at, (uint32_t)c->pressure_min_pa);
    at = put32(at, (uint32_t)c->pressure_max_pa);
    at = put32(at, (uint32_t)c->vent_pressure_pa);
    at = put16(at, c->angle_quantum);
    *at++ = c->proportional_valves;
    at = put16(at, c->pwm_hz);
    return exo_frame(payload, (size_t)(at - payload), out);
}

static size_t notice_frame(uint8_t code, uint8_t detail, uint8_t *out) {
    uint8_t payload[1 + NOTICE_BODY] = {EXO_NOTICE, code, detail};
    return exo_frame(payload, sizeof payload, out);
}

/* -- the board --------------------------------------------------------------------------- */

static void vent(uint16_t duties[EXO_VALVES]) {
    for (int i = 0; i < EXO_CHAMBERS; i++) {
        duties[i] = 0;
        duties[EXO_CHAMBERS + i] = EXO_DUTY_FULL;
    }
}

void exo_board_init(exo_board *board, const exo_capabilities *capabilities) {
    memset(board, 0, sizeof *board);
    board->capabilities = *capabilities;
    vent(board->commanded);
}

static size_t take(exo_board *board, const uint8_t *payload, size_t length, uint32_t now_us,
                   uint8_t *answer) {
    uint8_t type = payload[0];
    size_t body = length - 1;
    if (type != EXO_HELLO && type != EXO_OPENINGS && type != EXO_HEARTBEAT) {
        return notice_frame(EXO_UNKNOWN_TYPE, type, answer);
    }
    if ((type == EXO_HELLO && body != HELLO_BODY) ||
        (type == EXO_OPENINGS && body != OPENINGS_BODY) ||
        (type == EXO_HEARTBEAT && body != HEARTBEAT_BODY)) {
        return notice_frame(EXO_BAD_LENGTH, type, answer);
    }
    if (type == EXO_HELLO) {
        if (payload[1] == board->capabilities.version) {
            board->streaming = true;
            vent(board->commanded);
            board->applied_sequence = 0;
            board->sequence = 0;
            board->refused = false;
            board->tripped = false;
            board->last_valid_us = now_us;
        }
        return capabilities_frame(&board->capabilities, answer);
    }
    if (!board->streaming) {
        return notice_frame(EXO_NOT_STREAMING, type, answer);
    }
    board->last_valid_us = now_us;
    if (type == EXO_HEARTBEAT) {
        return 0;
    }
    for (int i = 0; i < EXO_VALVES; i++) {
        if (get16(payload + 3 + 2 * i) > EXO_DUTY_FULL) {
            board->refused = true;
            return notice_frame(EXO_BAD_OPENINGS, (uint8_t)i, answer);
        }
    }
    board->refused = false;
    board->tripped = false;
    for (int i = 0; i < EXO_VALVES; i++) {
        board->commanded[i] = get16(payload + 3 + 2 * i);
    }
    board->applied_sequence = get16(payload + 1);
    return 0;
}

/* The checked payload of the frame just ended, or 0 (a bad frame, counted). */
static size_t end_of_frame(exo_board *board, uint8_t *payload) {
    size_t length = exo_cobs_decode(board->received, board->received_length, payload);
    if (length == (size_t)-1 || length <= CRC_BYTES) {
        board->receive_errors = true;
        return 0;
    }
    length -= CRC_BYTES;
    uint16_t crc = (uint16_t)(payload[length] | (uint16_t)payload[length + 1] << 8);
    if (exo_crc16(payload, length) != crc) {
        board->receive_errors = true;
        return 0;
    }
    return length;
}

size_t exo_board_receive(exo_board *board, uint8_t byte, uint32_t now_us, uint8_t *answer) {
    if (byte != 0) {
        if (board->overlong) {
            return 0;
        }
        if (board->received_length == EXO_MAX_STUFFED) {
            board->overlong = true;
            board->received_length = 0;
            board->receive_errors = true;
            return 0;
        }
        board->received[board->received_length++] = byte;
        return 0;
    }
    bool overlong = board->overlong;
    size_t received = board->received_length;
    board->overlong = false;
    if (overlong || received == 0) {
        board->received_length = 0;
        return 0;
    }
    uint8_t payload[EXO_MAX_STUFFED];
    size_t length = end_of_frame(board, payload);
    board->received_length = 0;
    if (length == 0) {
        return 0;
    }
    return take(board, payload, length, now_us, answer);
}

void exo_board_duties(exo_board *board, uint32_t now_us, uint16_t duties[EXO_VALVES]) {
    uint32_t quiet = now_us - board->last_valid_us; /* wraps correctly */
    if (board->streaming && quiet > (uint32_t)board->capabilities.watchdog_ms * 1000u) {
        board->tripped = true;
    }
    if (!board->streaming || board->tripped) {
        vent(duties);
        return;
    }
    memcpy(duties, board->commanded, sizeof board->commanded);
    for (int i = 0; i < EXO_CHAMBERS; i++) {
        if (board->over_pressure[i]) {
            duties[i] = 0;
            duties[EXO_CHAMBERS + i] = EXO_DUTY_FULL;
        }
    }
}

size_t exo_board_sample(exo_board *board, uint32_t now_us, const int32_t pressures_pa[EXO_CHAMBERS],
                        const int16_t *angles, uint16_t flags, uint8_t *out) {
    bool over = false;
    for (int i = 0; i < EXO_CHAMBERS; i++) {
        board->over_pressure[i] = pressures_pa[i] >= board->capabilities.vent_pressure_pa;
        over = over || board->over_pressure[i];
    }
    if (!board->streaming) {
        return 0;
    }
    uint16_t duties[EXO_VALVES];
    exo_board_duties(board, now_us, duties);
    uint16_t status = (uint16_t)(flags & (EXO_SUPPLY_LOW | EXO_SENSOR_FAULT));
    if (board->tripped) {
        status |= EXO_WATCHDOG_VENT;
    }
    if (over) {
        status |= EXO_OVER_PRESSURE;
    }
    if (board->refused) {
        status |= EXO_COMMAND_REFUSED;
    }
    if (board->receive_errors) {
        status |= EXO_RECEIVE_ERRORS;
        board->receive_errors = false;
    }
    uint8_t payload[1 + SAMPLE_BODY + ANGLES_BODY];
    uint8_t *at = payload;
    *at++ = EXO_SAMPLE;
    at = put16(at, board->sequence);
    at = put32(at, now_us);
    at = put16(at, status);
    at = put16(at, board->applied_sequence);
    for (int i = 0; i < EXO_CHAMBERS; i++) {
        at = put32(at, (uint32_t)pressures_pa[i]);
    }
    if (board->capabilities.bend_sensors && angles != NULL) {
        for (int i = 0; i < EXO_CHAMBERS; i++) {
            at = put16(at, (uint16_t)angles[i]);
        }
    }
    board->sequence++;
    return exo_frame(payload, (size_t)(at - payload), out);
}
