/*
 * exodigit_board: the reference firmware of a glove board, protocol version 1
 * (docs/spec/hardware.md; wiring: docs/hardware.md, "The reference board").
 *
 * Board: Arduino Uno R3 (ATmega328P, 5 V, 16 MHz), USB serial at 115200 baud.
 * Per chamber (MCP, PIP, DIP): an NXP MPX5100GP pressure sensor (0-100 kPa gauge, analogue
 * 0.2-4.7 V) on A0-A2; an inlet valve (normally closed) and an outlet valve (normally open,
 * so an unpowered board vents), each a 12 V solenoid switched by a logic-level MOSFET from the
 * six PWM pins. Optional: a flex sensor per joint on A3-A5 (set BEND_SENSORS to 0 without).
 *
 * The protocol is src/link/exo_link.c (portable C, tested on the host by the suite); this file
 * only reads the sensors, drives the valves and moves bytes.
 */
#include "src/link/exo_link.h"

/* -- what is fitted --------------------------------------------------------------------- */

#define BEND_SENSORS 3                /* 0 without flex sensors */
#define SAMPLE_PERIOD_US 10000UL       /* 100 Hz */
#define WATCHDOG_MS 200                /* no valid frame for this long: vent */
#define VENT_PRESSURE_PA 95000L        /* a chamber at or above it is vented by the board */
#define OUTLET_NORMALLY_OPEN 1         /* energising an outlet valve closes it */

static const uint8_t VALVE_PINS[EXO_VALVES] = {3, 5, 6, 9, 10, 11}; /* inlets, then outlets */
static const uint8_t PRESSURE_PINS[EXO_CHAMBERS] = {A0, A1, A2};
static const uint8_t BEND_PINS[EXO_CHAMBERS] = {A3, A4, A5};

/* MPX5100GP: Vout = Vs (0.009 P/kPa + 0.04); with the ADC's reference at Vs,
 * P = (counts / 1023 - 0.04) / 0.009 kPa, one count = 108.6 Pa. */
#define PRESSURE_QUANTUM_PA 109
#define PRESSURE_MAX_PA 100000L
#define SENSOR_MISSING_COUNTS 20       /* below the sensor's 0.2 V offset: unplugged */

/* Flex sensors (with a 47 kOhm divider): angle = (counts - straight) * step, calibrated per
 * glove by reading the counts at 0 and at a known angle. In 1/10,000 rad. */
static const int16_t BEND_STRAIGHT_COUNTS[EXO_CHAMBERS] = {310, 310, 310};
static const int16_t BEND_STEP = 58;   /* 1/10,000 rad per count (~0.33 degree) */

/* -- state ------------------------------------------------------------------------------- */

static exo_board board;
static uint8_t frame[EXO_MAX_FRAME];
static unsigned long next_sample_us;

static int32_t pressure_pa(uint8_t pin, bool *fault) {
    int counts = analogRead(pin);
    if (counts < SENSOR_MISSING_COUNTS) {
        *fault = true;
    }
    /* (counts / 1023 - 0.04) / 0.009 kPa, in Pa, clipped to the sensor's range */
    int32_t pa = (int32_t)((counts * 1000000L / 1023L - 40000L) / 9L);
    if (pa < 0) {
        pa = 0;
    }
    if (pa > PRESSURE_MAX_PA) {
        pa = PRESSURE_MAX_PA;
    }
    return pa;
}

static void drive_valves(const uint16_t duties[EXO_VALVES]) {
    for (uint8_t i = 0; i < EXO_VALVES; i++) {
        /* duty 0..10,000 as an 8-bit PWM value */
        uint8_t level = (uint8_t)(((uint32_t)duties[i] * 255UL + EXO_DUTY_FULL / 2) / EXO_DUTY_FULL);
        if (OUTLET_NORMALLY_OPEN && i >= EXO_CHAMBERS) {
            level = (uint8_t)(255 - level); /* open = not energised */
        }
        analogWrite(VALVE_PINS[i], level);
    }
}

void setup() {
    exo_capabilities capabilities = {
        EXO_PROTOCOL_VERSION,
        {1, 0, 0},                       /* firmware version */
        EXO_CHAMBERS,
        BEND_SENSORS,
        (uint16_t)(1000000UL / SAMPLE_PERIOD_US),
        WATCHDOG_MS,
        PRESSURE_QUANTUM_PA,
        0,
        PRESSURE_MAX_PA,
        VENT_PRESSURE_PA,
        BEND_SENSORS ? (uint16_t)BEND_STEP : (uint16_t)0,
        1,                               /* proportional (PWM) valves */
        490,                             /* the Uno's PWM frequency on most of these pins, Hz */
    };
    exo_board_init(&board, &capabilities);
    uint16_t duties[EXO_VALVES];
    exo_board_duties(&board, micros(), duties); /* silent: vented */
    for (uint8_t i = 0; i < EXO_VALVES; i++) {
        pinMode(VALVE_PINS[i], OUTPUT);
    }
    drive_valves(duties);
    Serial.begin(115200);
    next_sample_us = micros() + SAMPLE_PERIOD_US;
}

void loop() {
    while (Serial.available() > 0) {
        size_t length = exo_board_receive(&board, (uint8_t)Serial.read(), micros(), frame);
        if (length > 0) {
            Serial.write(frame, length);
        }
    }
    unsigned long now = micros();
    if ((long)(now - next_sample_us) >= 0) {
        next_sample_us += SAMPLE_PERIOD_US;
        bool fault = false;
        int32_t pressures[EXO_CHAMBERS];
        int16_t angles[EXO_CHAMBERS];
        for (uint8_t i = 0; i < EXO_CHAMBERS; i++) {
            pressures[i] = pressure_pa(PRESSURE_PINS[i], &fault);
            long angle = (long)(analogRead(BEND_PINS[i]) - BEND_STRAIGHT_COUNTS[i]) * BEND_STEP;
            angles[i] = (int16_t)(angle > 32767L ? 32767L : angle < -32767L ? -32767L : angle);
        }
        uint16_t flags = fault ? EXO_SENSOR_FAULT : 0;
        size_t length = exo_board_sample(&board, now, pressures, BEND_SENSORS ? angles : NULL,
                                         flags, frame);
        if (length > 0) {
            Serial.write(frame, length);
        }
    }
    uint16_t duties[EXO_VALVES];
    exo_board_duties(&board, micros(), duties);
    drive_valves(duties);
}
