/* Just enough of the Arduino core's interface to compile the sketch on the host
 * (tests/test_hardware_firmware.py): declarations only, nothing runs. */
#ifndef ARDUINO_STUB_H
#define ARDUINO_STUB_H
#include <stddef.h>
#include <stdint.h>

#define OUTPUT 1
enum { A0 = 14, A1, A2, A3, A4, A5 };

int analogRead(uint8_t pin);
void analogWrite(uint8_t pin, int value);
void pinMode(uint8_t pin, uint8_t mode);
unsigned long micros(void);

struct SerialPort {
    void begin(unsigned long baud);
    int available(void);
    int read(void);
    size_t write(const uint8_t *data, size_t length);
};
extern SerialPort Serial;
#endif
