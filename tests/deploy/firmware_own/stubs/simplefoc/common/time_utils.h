// encal test stub: the Arduino timing calls, as no-ops (the host harness does not wait).
#ifndef ENCAL_STUB_TIME_UTILS_H
#define ENCAL_STUB_TIME_UTILS_H
static inline void _delay(unsigned long) {}
static inline unsigned long _micros() { return 0; }
static inline void delay(unsigned long) {}
static inline void delayMicroseconds(unsigned int) {}
#endif
