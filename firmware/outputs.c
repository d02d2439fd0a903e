/* User outputs (see outputs.h). */
#include <avr/io.h>
#include <avr/pgmspace.h>

#include "board.h"
#include "device.h"
#include "irq.h"
#include "outputs.h"
#include "proto.h"
#include "stepgen.h"

#define O_ANALOG 0x01
#define O_SYNCHRONIZED 0x02
#define PWM_COUNTS 256  /* TOP 255 on both 8-bit timers */

/* the PWM pins: their timer's compare register and output mode bits */
enum { PWM_OC2B, PWM_OC2A, PWM_OC0B, PWM_OC0A, PWM_UNITS };
/* (tables in flash: the RAM is for the queues) */
static const uint8_t pwm_pin[PWM_UNITS] PROGMEM = {3, 11, 5, 6};
static uint8_t pwm_on;  /* bit per unit: configured by OutputPwm */

#define SYNC_CHANGES 8
static struct {
    uint8_t flags;
    uint8_t pin;
    uint16_t value;
} waiting[SYNC_CHANGES];
static uint8_t waiting_count;

void outputs_init(void)
{
    /* timer 0: fast PWM, TOP 255, prescaler 64 - its overflow every 1.024 ms is the
     * main loop's tick; its outputs stay disconnected until used */
    TCCR0A = _BV(WGM01) | _BV(WGM00);
    TCCR0B = _BV(CS01) | _BV(CS00);
    TIMSK0 = _BV(TOIE0);
}

static int8_t unit_of(uint8_t pin)
{
    for (uint8_t u = 0; u < PWM_UNITS; u++)
        if (pgm_read_byte(&pwm_pin[u]) == pin)
            return (int8_t)u;
    return -1;
}

/* The duty: `count` of 256 timer counts high (0: low, 256 or more: high). */
static void duty(uint8_t unit, uint32_t count)
{
    static const uint16_t ocr_reg[PWM_UNITS] PROGMEM = {
        (uint16_t)&OCR2B, (uint16_t)&OCR2A, (uint16_t)&OCR0B, (uint16_t)&OCR0A};
    static const uint16_t tccra_reg[PWM_UNITS] PROGMEM = {
        (uint16_t)&TCCR2A, (uint16_t)&TCCR2A, (uint16_t)&TCCR0A, (uint16_t)&TCCR0A};
    static const uint8_t com_bits[PWM_UNITS] PROGMEM = {
        _BV(COM2B1), _BV(COM2A1), _BV(COM0B1), _BV(COM0A1)};
    volatile uint8_t *ocr = (volatile uint8_t *)pgm_read_word(&ocr_reg[unit]);
    volatile uint8_t *tccra = (volatile uint8_t *)pgm_read_word(&tccra_reg[unit]);
    uint8_t com = pgm_read_byte(&com_bits[unit]);
    uint8_t pin = pgm_read_byte(&pwm_pin[unit]);
    uint8_t sreg = irq_save();
    if (count == 0) {
        *tccra &= (uint8_t)~com;  /* disconnected: the port holds it low */
        board_pin_write(pin, 0);
    } else {
        *ocr = count >= PWM_COUNTS ? 255 : (uint8_t)(count - 1);  /* high for count */
        board_pin_write(pin, 0);
        *tccra |= com;  /* non-inverting: high from BOTTOM to the match */
    }
    irq_restore(sreg);
}

void outputs_pwm(const uint8_t *m)
{
    uint8_t pin = m[2];
    uint32_t clock_div = get_u32(m + 3), counts = get_u32(m + 7), count = get_u32(m + 11);
    int8_t unit = unit_of(pin);
    if (unit < 0 || counts != PWM_COUNTS) {
        counters.rejected++;  /* no PWM hardware there, or a TOP these timers cannot have */
        return;
    }
    if (unit <= PWM_OC2A) {
        static const uint16_t prescalers[7] PROGMEM = {1, 8, 32, 64, 128, 256, 1024};
        uint8_t cs = 0;
        for (uint8_t i = 0; i < 7; i++)
            if (pgm_read_word(&prescalers[i]) == clock_div)
                cs = i + 1;
        if (!cs) {
            counters.rejected++;
            return;
        }
        uint8_t sreg = irq_save();
        TCCR2A = (uint8_t)((TCCR2A & (_BV(COM2A1) | _BV(COM2A0) | _BV(COM2B1) | _BV(COM2B0)))
                           | _BV(WGM21) | _BV(WGM20));
        TCCR2B = cs;
        irq_restore(sreg);
    } else if (clock_div != 64) {
        counters.rejected++;  /* timer 0 keeps prescaler 64: it is the 1 ms tick too */
        return;
    }
    pwm_on |= 1u << unit;
    duty((uint8_t)unit, count);
}

static void make(uint8_t flags, uint8_t pin, uint32_t value)
{
    if (flags & O_ANALOG) {
        int8_t unit = unit_of(pin);
        if (unit < 0 || !(pwm_on & (1u << unit))) {
            counters.rejected++;  /* no PWM set up on that pin */
            return;
        }
        duty((uint8_t)unit, value);
    } else if (board_pin_usable(pin)) {
        board_pin_write(pin, value ? 1 : 0);
    } else {
        counters.rejected++;
    }
}

void outputs_set(const uint8_t *m)
{
    uint8_t flags = m[1], pin = m[3];
    uint32_t value = get_u32(m + 4);
    if (!(flags & O_SYNCHRONIZED)) {
        make(flags, pin, value);
        return;
    }
    if (device_locked || waiting_count == SYNC_CHANGES) {
        counters.rejected++;
        return;
    }
    waiting[waiting_count].flags = flags;
    waiting[waiting_count].pin = pin;
    waiting[waiting_count].value = value > 0xFFFF ? 0xFFFF : (uint16_t)value;
    waiting_count++;
    outputs_poll();
}

void outputs_cancel(void)
{
    waiting_count = 0;
}

void outputs_poll(void)
{
    if (!waiting_count)
        return;
    for (uint8_t ch = 0; ch < FW_MAX_STEPPERS; ch++) {
        struct stepq *q = &stepq[ch];
        if (devq[ch].configured && (q->state || q->rp != q->wp))
            return;  /* motion commanded before the changes is not done */
    }
    for (uint8_t i = 0; i < waiting_count; i++)
        make(waiting[i].flags, waiting[i].pin, waiting[i].value);
    waiting_count = 0;
}
