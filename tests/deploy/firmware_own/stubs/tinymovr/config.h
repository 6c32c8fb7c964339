/* encal test stub (written for encal, not Tinymovr's file): the configuration common.h and sensor.h read. */
#ifndef ENCAL_STUB_CONFIG_H
#define ENCAL_STUB_CONFIG_H
#define ECN_BITS (6)
#define ECN_SIZE (1 << ECN_BITS)
#define ACLK_FREQ_HZ (300000000)
#define TXCTL_PS_DIV (1)
#define PWM_FREQ_HZ (20000)
#endif
