/* Message types, sizes and flags of docs/serial-protocol.md (version 2).
 * Sizes include the type byte; multi-byte fields are little-endian. */
#ifndef FW_PROTO_H
#define FW_PROTO_H

#include <stdint.h>

#define PROTOCOL_VERSION 2
#define SEQ_UNSEQUENCED 0x80
#define SEQ_MASK 0x7F

/* host -> device */
#define M_HELLO 0x01           /* version u8, nonce u16, watchdog_ms u16, report_ms u8 */
#define M_SYNC_REQUEST 0x02    /* stamp u32 */
#define M_CONFIG 0x03          /* stepper, step_pin, dir_pin, index u8; end_pos i32 */
#define M_DIR_PIN 0x04         /* stepper, dir_pin */
#define M_TRUNCATE 0x05        /* stepper, index */
#define M_START 0x06           /* mask u8, at u32 */
#define M_FORCE_STOP 0x07      /* stepper, index, stop_id */
#define M_SET_END_POS 0x08     /* stepper u8, pos i32 */
#define M_PIN 0x09             /* pin, level */
#define M_DETACH 0x0A          /* stepper, detached */
#define M_PCNT_ATTACH 0x0B     /* stepper u8, low i16, high i16, dir_high_counts_up u8, value i16 */
#define M_PCNT_CLEAR 0x0C      /* stepper */
#define M_STATUS_REQUEST 0x0D  /* - */
#define M_ESTOP 0x0E           /* nonce u16 */
#define M_BYE 0x0F             /* nonce u16 */
#define M_HALT 0x10            /* stepper u8, stop_id u8, nonce u16 */
#define M_ENTRY 0x40           /* 0x40 | stepper: flags u8, steps u8, ticks u16 */
#define M_OUTPUT_PWM 0x20      /* number, pin u8; clock_div, counts, count u32 */
#define M_OUTPUT_SET 0x21      /* flags, number, pin u8; value u32 */
#define M_OUTPUT_CANCEL 0x22   /* - */
#define M_OUTPUT_AT 0x23       /* flags, number, pin u8; value u32, at u32 (device tick) */
#define M_OUTPUT_NEXT 0x24     /* value u16, after u16: the last timed change's output */
#define M_WATCH_INPUT 0x30     /* pin, mode, period_ms (section 18) */
#define M_LIMIT 0x31           /* stepper, pin, level, flags, stop_mask */
#define M_SET_INPUT 0x32       /* pin u8, value u16, flags u8: a simulated device's world */

#define E_INDEX_MASK 0x0F
#define E_TOGGLE_DIR 0x10
#define E_DIR_LEVEL 0x20
#define E_COUNT_UP 0x40
#define E_CONT 0x80

/* device -> host */
#define M_IDENT 0x81
#define M_SYNC_REPLY 0x82      /* stamp u32, device_tick u32 */
#define M_STATUS 0x84          /* 17 bytes */
#define M_DEVICE_STATUS 0x85   /* 48 bytes */
#define M_NAK 0x86             /* expected u8, held u16 */
#define M_PWM_GRID 0x87        /* pin u8, origin u32, period u32 (section 16) */
#define M_PROGRESS 0x50        /* 0x50 | stepper: flags, index, steps_left, [pcnt i16] */
#define M_INPUT 0xA0           /* pin u8, value u16, tick u32 */
#define M_LIMIT_HIT 0xA1       /* stepper, pin, index u8, position i32, tick u32 */
#define M_STARTED 0xA2         /* stepper u8, tick u32 */

#define SIZE_IDENT_FIXED 25    /* before the name */
#define SIZE_SYNC_REPLY 9
#define SIZE_STATUS 17
#define SIZE_DEVICE_STATUS 48
#define SIZE_NAK 4
#define SIZE_PWM_GRID 10
#define SIZE_PROGRESS_MAX 6
#define SIZE_INPUT 8
#define SIZE_LIMIT_HIT 12
#define SIZE_STARTED 6

/* Ident features: optional message families */
#define F_INPUTS 0x0001        /* section 18: inputs, limit switches, Started */
#define F_SIM_INPUTS 0x0002    /* SetInput: the inputs are a simulation's (simavr) */
#define F_TIMED_OUTPUTS 0x0004 /* OutputAt: timed output changes (section 16) */

/* WatchInput modes, Limit flags, SetInput flags */
#define W_OFF 0
#define W_DIGITAL 1
#define W_PULLUP 2
#define W_ANALOG 3
#define L_UP 0x01
#define L_CLEAR 0x80
#define S_ANALOG 0x01

/* Progress / Status flags */
#define P_RUNNING 0x01
#define P_HAS_ENTRY 0x02
#define P_HAS_PCNT 0x04
#define P_START_PENDING 0x08
#define P_DETACHED 0x10
#define P_CUT_REFUSED 0x20
#define P_HALTED 0x40

/* DeviceStatus state */
#define D_WATCHDOG 0x01
#define D_ESTOP 0x02
#define D_SESSION 0x04

/* The size of a host message from its type byte (0: a type this device does not
 * know); a reader must know a type to step over it. */
uint8_t proto_host_message_size(uint8_t type);

static inline uint16_t get_u16(const uint8_t *p)
{
    return (uint16_t)p[0] | ((uint16_t)p[1] << 8);
}

static inline uint32_t get_u32(const uint8_t *p)
{
    return (uint32_t)get_u16(p) | ((uint32_t)get_u16(p + 2) << 16);
}

static inline uint8_t *put_u16(uint8_t *p, uint16_t v)
{
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    return p + 2;
}

static inline uint8_t *put_u32(uint8_t *p, uint32_t v)
{
    p = put_u16(p, (uint16_t)v);
    return put_u16(p, (uint16_t)(v >> 16));
}

#endif
