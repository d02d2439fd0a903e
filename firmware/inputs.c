/* Inputs of the board (see inputs.h). */
#include <avr/io.h>

#include "board.h"
#include "device.h"
#include "inputs.h"
#include "irq.h"
#include "limits.h"
#include "proto.h"
#include "ticks.h"
#include "uart.h"

#define ANALOG_FIRST 14   /* A0 */
#define ANALOG_PINS 8     /* A0-A7 (A6, A7: analog only, on the Nano) */
#define DEFAULT_PERIOD_MS 50
#define UNIT_SHIFT 10     /* analog sample times in units of 1024 ticks (64 us) */
#define UNITS_PER_MS(ms) ((uint16_t)((ms) * 125u / 8u))

/* The harness of the simulator (firmware/simavr) marks the chip at reset and takes
 * SetInput from these registers; on a board they are 0 at reset and stay unused. */
#define SIM_MARK_1 0xA5
#define SIM_MARK_2 0x5A
#define SIM_GO 0x80
#define SIM_ANALOG 0x40

struct watch {
    uint8_t pin;
    uint8_t mode;      /* W_*: W_OFF is a free entry */
    uint16_t period;   /* analog: sample period in units */
    uint16_t next;     /* analog: the next sample (units, wraps) */
    uint16_t value;    /* the value last read (reported or due) */
    uint32_t tick;     /* the tick it was read at */
};
static struct watch watches[WATCHES];
static uint8_t due;    /* bit per watch: an Input to send */
static uint8_t put;    /* ... in the frame being built */
volatile uint32_t inputs_change_tick;  /* set by the pin-change interrupt (limits.c) */
volatile uint8_t inputs_changed;
uint8_t inputs_simulated;


void inputs_init(void)
{
    inputs_simulated = GPIOR1 == SIM_MARK_1 && GPIOR2 == SIM_MARK_2;
    GPIOR1 = 0;
    GPIOR2 = 0;
}

void inputs_reset(void)
{
    for (uint8_t i = 0; i < WATCHES; i++)
        watches[i].mode = W_OFF;
    due = 0;
    inputs_update_pcint();
}

static uint16_t read_analog(uint8_t pin)
{
    /* AVcc reference, 125 kHz conversion clock: 104 us (the first 200 us) */
    ADMUX = _BV(REFS0) | (uint8_t)(pin - ANALOG_FIRST);
    ADCSRA = _BV(ADEN) | _BV(ADSC) | _BV(ADPS2) | _BV(ADPS1) | _BV(ADPS0);
    while (ADCSRA & _BV(ADSC))
        ;
    return ADC;
}

static uint16_t read_input(const struct watch *w)
{
    if (w->mode == W_ANALOG)
        return read_analog(w->pin);
    return (*board_pin_reg(w->pin) & board_pin_mask(w->pin)) ? 1 : 0;
}

void inputs_update_pcint(void)
{
    uint8_t mask[3] = {0, 0, 0};
    for (uint8_t i = 0; i < WATCHES; i++) {
        const struct watch *w = &watches[i];
        if (w->mode != W_OFF && w->mode != W_ANALOG)
            mask[board_pin_port(w->pin)] |= board_pin_mask(w->pin);
    }
    limits_pcint_mask(mask);
    uint8_t sreg = irq_save();
    PCMSK0 = mask[0];
    PCMSK1 = mask[1];
    PCMSK2 = mask[2];
    PCICR = (mask[0] ? _BV(PCIE0) : 0) | (mask[1] ? _BV(PCIE1) : 0) | (mask[2] ? _BV(PCIE2) : 0);
    irq_restore(sreg);
}

void inputs_watch(const uint8_t *m)
{
    uint8_t pin = m[1], mode = m[2];
    struct watch *w = 0, *free_w = 0;
    for (uint8_t i = 0; i < WATCHES; i++) {
        if (watches[i].mode == W_OFF) {
            if (!free_w)
                free_w = &watches[i];
        } else if (watches[i].pin == pin) {
            w = &watches[i];
        }
    }
    if (mode == W_OFF) {
        if (w) {
            w->mode = W_OFF;
            due &= (uint8_t)~(1u << (w - watches));
            inputs_update_pcint();
        }
        return;
    }
    uint8_t analog = (uint8_t)(pin - ANALOG_FIRST) < ANALOG_PINS;
    if (!w)
        w = free_w;
    if (!w || mode > W_ANALOG || (mode == W_ANALOG ? !analog : !board_pin_usable(pin))) {
        counters.rejected++;  /* no such input, or every watch taken */
        return;
    }
    uint8_t didr = pin < ANALOG_FIRST + 6 && analog ? (uint8_t)(1u << (pin - ANALOG_FIRST)) : 0;
    if (mode == W_ANALOG) {
        if (board_pin_usable(pin))
            board_pin_input(pin, 0);  /* a pot drives it: no pull-up */
        DIDR0 |= didr;                /* its digital input buffer off */
    } else {
        DIDR0 &= (uint8_t)~didr;
        board_pin_input(pin, mode == W_PULLUP);
        __builtin_avr_delay_cycles(32);  /* the pull-up and the synchronizer settle */
    }
    w->pin = pin;
    w->mode = mode;
    w->period = UNITS_PER_MS(m[3] ? m[3] : DEFAULT_PERIOD_MS);
    w->value = read_input(w);
    uint32_t now = ticks_now();
    w->tick = now;
    w->next = (uint16_t)(now >> UNIT_SHIFT) + w->period;
    due |= (uint8_t)(1u << (w - watches));  /* the answer: the value now */
    inputs_update_pcint();
}

void inputs_world(const uint8_t *m)
{
    if (!inputs_simulated) {
        counters.rejected++;  /* a board's inputs are its pins */
        return;
    }
    uint16_t value = get_u16(m + 2);
    GPIOR1 = m[1];
    GPIOR2 = (uint8_t)value;
    GPIOR0 = (uint8_t)(SIM_GO | ((m[4] & S_ANALOG) ? SIM_ANALOG : 0) | ((value >> 8) & 0x03));
}

void inputs_poll(void)
{
    uint8_t sreg = irq_save();
    uint8_t pin_changed = inputs_changed;
    uint32_t changed_at = inputs_change_tick;
    inputs_changed = 0;
    irq_restore(sreg);
    for (uint8_t i = 0; i < WATCHES; i++) {
        struct watch *w = &watches[i];
        if (w->mode == W_OFF)
            continue;
        uint32_t now = ticks_now();
        uint32_t tick = now;
        if (w->mode == W_ANALOG) {
            uint16_t units = (uint16_t)(now >> UNIT_SHIFT);
            if ((int16_t)(units - w->next) < 0)
                continue;
            w->next += w->period;
            if ((int16_t)(units - w->next) >= 0)
                w->next = units + w->period;  /* far behind: from now on */
        } else if (pin_changed) {
            tick = changed_at;
        }
        uint16_t v = read_input(w);
        if (w->mode == W_ANALOG)
            tick = ticks_now();  /* the result is read out now */
        if (v != w->value) {
            w->value = v;
            w->tick = tick;
            due |= (uint8_t)(1u << i);
        }
    }
}

void inputs_refresh(void)
{
    for (uint8_t i = 0; i < WATCHES; i++)
        if (watches[i].mode != W_OFF)
            due |= (uint8_t)(1u << i);
}

uint8_t inputs_due(void)
{
    return due;
}

uint8_t inputs_put(uint8_t *p, uint8_t room)
{
    uint8_t n = 0;
    put = 0;
    for (uint8_t i = 0; i < WATCHES; i++) {
        if (!(due & (1u << i)) || n + SIZE_INPUT > room)
            continue;
        const struct watch *w = &watches[i];
        p[n] = M_INPUT;
        p[n + 1] = w->pin;
        put_u32(put_u16(p + n + 2, w->value), w->tick);
        n += SIZE_INPUT;
        put |= (uint8_t)(1u << i);
    }
    return n;
}

void inputs_sent(void)
{
    due &= (uint8_t)~put;
    put = 0;
}
