/* Build-time figures of the device firmware (ATmega328P, Arduino Uno/Nano).
 *
 * They must agree with the host's profile table (fas/arch.py, profile "atmega328p"):
 * the host compares what Ident reports with its own table and refuses a mismatch.
 */
#ifndef FW_CONFIG_H
#define FW_CONFIG_H

#ifndef F_CPU
#define F_CPU 16000000UL
#endif

/* Line speed: 115200 (default) or 1000000; `make BAUD=1000000`. Both use the UART's
 * double-speed mode (U2X): 115200 is really 117647 baud (+2.1 %, as the Arduino core
 * does it), 1000000 is exact at 16 MHz. */
#ifndef BAUD
#define BAUD 115200UL
#endif

#define FW_NAME "atmega328p"          /* the profile the host looks up */
#define FW_TICKS_PER_S 16000000UL     /* timer 1 runs at the CPU clock */
#define FW_MAX_STEPPERS 2             /* timer 1 channels A and B: pins 9 and 10 */
#define FW_MIN_CMD_TICKS_DIV 25000U   /* ticks_per_s / min_cmd_ticks */

/* One command queue per stepper: a ring of QUEUE_LEN entries (a power of two), as
 * FastAccelStepper's AVR queue. */
#ifndef QUEUE_LEN
#define QUEUE_LEN 64
#endif
#define QUEUE_MASK (QUEUE_LEN - 1)

/* Out-of-order frame slots (selective repeat) and the largest host frame payload */
#define RX_SLOTS 8
#define SLOT_PAYLOAD 32

#define DEFAULT_WATCHDOG_MS 500
#define DEFAULT_REPORT_MS 2
#define STATUS_MS 100           /* every queue's Progress (a lost report heals) */
#define DEVICE_STATUS_EVERY 5   /* ... and every 5th time a DeviceStatus */

/* EEPROM: a boot counter (the boot id tells the host whether the device restarted)
 * and the rate of the tick counter per second of the host's clock when it is not
 * ticks_per_s (a simulated chip run faster than real time; 0xFFFFFFFF: not set). */
#define EE_BOOT_COUNT 0         /* u16 */
#define EE_CLOCK_HZ 2           /* u32 */

#define STEP_PIN_A 9   /* OC1A, PB1 */
#define STEP_PIN_B 10  /* OC1B, PB2 */

#endif
