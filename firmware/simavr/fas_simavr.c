/*
 * fas-simavr: runs the device firmware in simavr (Debian's libsimavr), bridges its
 * UART to the host and records the pins with their cycle times.
 *
 *   fas-simavr [--pty] [--link PATH] [--speed F] [--trace FILE] FIRMWARE.elf
 *       serves a new pseudo-terminal (its path is the first line on stdout) and runs
 *       the simulated chip in real time (or F times faster); ends on SIGINT/SIGTERM
 *       and prints a summary.  Lines "PIN VALUE [a]" on standard input set inputs.
 *
 * The same file, built as a shared library (-DFAS_SIMAVR_LIB, libfassimavr.so), is the
 * chip for co-simulation: fs_open(), then fs_run() hands it the bytes the host sent
 * and runs it to a given cycle, returning the bytes it sent; the chip advances only
 * when told to, so runs are deterministic (fas/device/simavr.py, SimavrDevice).
 * One chip per process at a time.
 *
 * The pins.  simavr 1.6 models the ports well, but not the timers' output-compare
 * pins: a PORTB write also drives OC1A/OC1B, and in normal mode an overflow (or an
 * OCR write) sets the pin as a PWM mode would.  This harness therefore keeps its own
 * output flip-flop for OC1A and OC1B that changes only at real compare matches, as
 * the ATmega328P does (set, clear or toggle by the COM1x bits; force-output-compare,
 * which simavr 1.6 does not model, is not modelled here either), and takes pins 9
 * and 10 from it while the compare output is connected, from PORTB otherwise.
 * Compare matches are time-stamped at their exact cycle.
 *
 * The world outside the board.  Inputs are set from outside (fs_input(), or lines
 * "PIN VALUE [a]" on standard input of the pty program): a digital level on a pin (a
 * switch; it overrides the pull-up, as a switch to ground does), or an analog value
 * 0..1023 on A0-A7 (a pot; AVcc is 5 V and the voltage is the one simavr's A/D
 * converter reads back as that value; the pin then reads high from 512 up).  A level
 * on an analog pin reads 0 or 1023 there.  Untouched analog inputs read 512 (centred
 * pots).  The harness marks the chip as simulated at reset (GPIOR1 = 0xA5, GPIOR2 =
 * 0x5A; a board has 0 there), and the firmware then forwards the protocol's SetInput:
 * pin to GPIOR1, value bits 0-7 to GPIOR2, then GPIOR0 = 0x80 | analog 0x40 | value
 * bits 8-9 - this harness's hook on GPIOR0 makes the change at that cycle.
 *
 * The trace file has a header of '#' lines, then one line per pin change:
 * "cycle pin level"; an analog input's change is a comment "#A cycle pin value".
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <inttypes.h>
#include <poll.h>
#include <signal.h>
#include <stdarg.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include "sim_avr.h"
#include "sim_elf.h"
#include "sim_io.h"
#include "sim_cycle_timers.h"
#include "avr_ioport.h"
#include "avr_timer.h"
#include "avr_uart.h"
#include "avr_eeprom.h"
#include "avr_adc.h"

#define PINS 20
#define REG_PINB 0x23
#define REG_DDRB 0x24
#define REG_PORTB 0x25
#define REG_TCCR1A 0x80
#define REG_TCCR1B 0x81
#define REG_OCR1AL 0x88
#define REG_OCR1BL 0x8A
#define REG_TCCR2A 0xB0
#define REG_TCCR2B 0xB1
#define REG_OCR2A 0xB3
#define REG_UCSR0B 0xC1
#define RXEN0_BIT 4
#define REG_GPIOR0 0x3E
#define REG_GPIOR1 0x4A
#define REG_GPIOR2 0x4B
#define SIM_MARK_1 0xA5
#define SIM_MARK_2 0x5A
#define SIM_GO 0x80
#define SIM_ANALOG 0x40

static avr_t *avr;
static FILE *trace;

/* ------------------------------------------------------------------ pins */
struct pin {
    uint8_t level;
    uint32_t rising;
    uint32_t falling;
};
static struct pin pins[PINS];
static uint8_t oc[2];           /* OC1A, OC1B output flip-flops */
static uint8_t tccr1a;          /* last value written */
static uint8_t oc2a;            /* OC2A as timer 2's compare output makes it (pin 11) */
static uint8_t tccr2a;          /* last value written */
static uint64_t timer1_start;   /* cycle at which timer 1 began counting */
static int timer1_started;

static void pin_set(int pin, int level, uint64_t cycle)
{
    struct pin *p = &pins[pin];
    level = level ? 1 : 0;
    if (p->level == level)
        return;
    p->level = (uint8_t)level;
    if (level)
        p->rising++;
    else
        p->falling++;
    if (trace)
        fprintf(trace, "%" PRIu64 " %d %d\n", cycle, pin, level);
}

/* pins 9 (OC1A, PB1) and 10 (OC1B, PB2) */
static void oc_pin_update(int ch, uint64_t cycle)
{
    int bit = ch ? 2 : 1;
    int com = (tccr1a >> (ch ? 4 : 6)) & 3;
    int ddr = (avr->data[REG_DDRB] >> bit) & 1;
    int level;
    if (!ddr)
        level = 0;
    else if (com)
        level = oc[ch];
    else
        level = (avr->data[REG_PORTB] >> bit) & 1;
    pin_set(ch ? 10 : 9, level, cycle);
}

/* pin 11 (OC2A, PB3): timer 2's PWM while COM2A is connected, PORTB otherwise */
static void oc2a_pin_update(uint64_t cycle)
{
    int level;
    if (!((avr->data[REG_DDRB] >> 3) & 1))
        level = 0;
    else if ((tccr2a >> 6) & 3)
        level = oc2a;
    else
        level = (avr->data[REG_PORTB] >> 3) & 1;
    pin_set(11, level, cycle);
}

static int arduino_pin(char port, int bit)
{
    switch (port) {
    case 'D': return bit;
    case 'B': return bit < 6 ? 8 + bit : -1;
    case 'C': return bit < 6 ? 14 + bit : -1;
    }
    return -1;
}

static void port_pin_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    int pin = (int)(intptr_t)param;
    if (pin == 9 || pin == 10 || pin == 11)
        return;  /* from the compare-output models instead */
    pin_set(pin, (int)(value & 0xFF), avr->cycle);
}

static void portb_write_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq; (void)value; (void)param;
    oc_pin_update(0, avr->cycle);
    oc_pin_update(1, avr->cycle);
    oc2a_pin_update(avr->cycle);
}

/* The exact cycle of the compare match of channel ch that is being handled (the
 * cycle timer runs a few cycles late, at the end of the current instruction). */
static uint64_t compare_cycle(int ch)
{
    uint16_t ocr = avr->data[REG_OCR1AL + 2 * ch] | (avr->data[REG_OCR1AL + 2 * ch + 1] << 8);
    uint64_t c = avr->cycle;
    uint16_t late = (uint16_t)(c - timer1_start - (uint16_t)(ocr + 1));
    return c - late;
}

static void comp_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    int ch = (int)(intptr_t)param;
    int com = (tccr1a >> (ch ? 4 : 6)) & 3;
    int v = value & 0xFF;
    /* simavr raises this line at compare matches and, in PWM fashion, on overflows and
     * OCR writes with the opposite level: only a level that a match in this mode
     * would produce is a match */
    switch (com) {
    case 1: oc[ch] ^= 1; break;            /* toggle */
    case 2: if (v) return; oc[ch] = 0; break;  /* clear */
    case 3: if (!v) return; oc[ch] = 1; break; /* set */
    default: return;
    }
    oc_pin_update(ch, compare_cycle(ch));
}

static void tccr1a_write(struct avr_t *a, avr_io_addr_t addr, uint8_t v, void *param)
{
    (void)a; (void)addr; (void)param;
    tccr1a = v;
    oc_pin_update(0, avr->cycle);
    oc_pin_update(1, avr->cycle);
}

/* Timer 2's OC2A as the ATmega328P makes it in fast PWM (TOP 255, COM2A 2: set at
 * BOTTOM, cleared at the match): simavr 1.6 takes an OCR2A write at once, where the
 * chip holds it until BOTTOM (double-buffered), and lets PORTB writes drive PB3.  So
 * the harness keeps its own counter: BOTTOM every 256 prescaled counts from the cycle
 * the clock was started (the firmware zeroes TCNT2 then), the OCR2A value latched
 * there, the pin set there and cleared (OCR2A + 1) counts later.  While COM2A is 0 the
 * pin is PORTB's and the output flip-flop keeps its level (the datasheet: the compare
 * unit acts on OC2A only in a compare output mode). */
static const uint16_t timer2_prescalers[8] = {0, 1, 8, 32, 64, 128, 256, 1024};
static uint32_t timer2_prescaler;  /* 0: stopped */

static avr_cycle_count_t oc2a_match(struct avr_t *a, avr_cycle_count_t when, void *param)
{
    (void)a; (void)param;
    oc2a = 0;
    oc2a_pin_update(when);
    return 0;
}

static avr_cycle_count_t timer2_bottom(struct avr_t *a, avr_cycle_count_t when, void *param)
{
    (void)a; (void)param;
    if (!timer2_prescaler)
        return 0;
    uint32_t ocr = avr->data[REG_OCR2A];
    if ((tccr2a >> 6) & 3) {  /* (disconnected, the flip-flop keeps its level) */
        oc2a = 1;
        oc2a_pin_update(when);
        if (ocr < 255)
            avr_cycle_timer_register(avr, when + (ocr + 1) * timer2_prescaler - avr->cycle,
                                     oc2a_match, NULL);
    }
    return when + 256 * timer2_prescaler;
}

static void tccr2b_write(struct avr_t *a, avr_io_addr_t addr, uint8_t v, void *param)
{
    (void)a; (void)addr; (void)param;
    uint32_t prescaler = timer2_prescalers[v & 7];
    avr->data[REG_TCCR2B] = v;
    if (prescaler == timer2_prescaler)
        return;
    avr_cycle_timer_cancel(avr, timer2_bottom, NULL);
    avr_cycle_timer_cancel(avr, oc2a_match, NULL);
    timer2_prescaler = prescaler;
    if (prescaler)  /* (counting on from 0: the first BOTTOM a period from now) */
        avr_cycle_timer_register(avr, 256 * prescaler, timer2_bottom, NULL);
}

static void tccr2a_write(struct avr_t *a, avr_io_addr_t addr, uint8_t v, void *param)
{
    (void)a; (void)addr; (void)param;
    tccr2a = v;
    avr->data[REG_TCCR2A] = v;
    oc2a_pin_update(avr->cycle);
}

static void tccr1b_write(struct avr_t *a, avr_io_addr_t addr, uint8_t v, void *param)
{
    (void)a; (void)addr; (void)param;
    if (!timer1_started && (v & 7)) {
        timer1_started = 1;
        timer1_start = avr->cycle;
    }
}

static void hook_pins(void)
{
    const char ports[] = {'B', 'C', 'D'};
    for (unsigned i = 0; i < sizeof ports; i++) {
        for (int bit = 0; bit < 8; bit++) {
            int pin = arduino_pin(ports[i], bit);
            if (pin < 0)
                continue;
            avr_irq_t *irq = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(ports[i]), bit);
            avr_irq_register_notify(irq, port_pin_hook, (void *)(intptr_t)pin);
        }
    }
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('B'), IOPORT_IRQ_REG_PORT),
                            portb_write_hook, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ('B'),
                                          IOPORT_IRQ_DIRECTION_ALL), portb_write_hook, NULL);
    for (int ch = 0; ch < 2; ch++)
        avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_TIMER_GETIRQ('1'),
                                              TIMER_IRQ_OUT_COMP + ch),
                                comp_hook, (void *)(intptr_t)ch);
    avr_register_io_write(avr, REG_TCCR1A, tccr1a_write, NULL);
    avr_register_io_write(avr, REG_TCCR2A, tccr2a_write, NULL);
    avr_register_io_write(avr, REG_TCCR2B, tccr2b_write, NULL);
    avr_register_io_write(avr, REG_TCCR1B, tccr1b_write, NULL);
}

/* ------------------------------------------------------------------ the world */
#define ANALOG_FIRST 14   /* A0 */
#define ANALOG_PINS 8     /* A0-A7 */
#define AVCC_MV 5000
#define ANALOG_DEFAULT 512
static uint8_t ext_mask[3], ext_value[3];  /* levels the world holds, ports B, C, D */
static uint32_t world_changes;

static uint32_t analog_mv(uint32_t value)
{
    /* simavr reads mV * 1023 / AVcc (rounded down): this is the least voltage read
     * back as `value` */
    return (value * AVCC_MV + 1022) / 1023;
}

static void world_analog(int channel, uint32_t value)
{
    avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, channel), analog_mv(value));
    if (trace)
        fprintf(trace, "#A %" PRIu64 " %d %" PRIu32 "\n", avr->cycle, ANALOG_FIRST + channel,
                value);
}

static void world_level(int pin, int level)
{
    char port = pin < 8 ? 'D' : pin < 14 ? 'B' : 'C';
    int bit = pin < 8 ? pin : pin < 14 ? pin - 8 : pin - 14;
    int i = port == 'B' ? 0 : port == 'C' ? 1 : 2;
    ext_mask[i] |= (uint8_t)(1u << bit);
    if (level)
        ext_value[i] |= (uint8_t)(1u << bit);
    else
        ext_value[i] &= (uint8_t)~(1u << bit);
    /* the level wins over the pull-up when the port is written again */
    avr_ioport_external_t ext = {.name = (unsigned)port, .mask = ext_mask[i],
                                 .value = ext_value[i]};
    avr_ioctl(avr, AVR_IOCTL_IOPORT_SET_EXTERNAL(port), &ext);
    avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(port), bit), level ? 1 : 0);
}

/* The world sets input `pin`: an analog value (a pot) or a level (a switch). */
static int world_input(int pin, uint32_t value, int analog)
{
    int is_analog_pin = pin >= ANALOG_FIRST && pin < ANALOG_FIRST + ANALOG_PINS;
    if (pin < 2 || pin >= ANALOG_FIRST + ANALOG_PINS || (analog && !is_analog_pin))
        return -1;  /* the UART's pins, or no such input */
    int level;
    if (analog) {
        if (value > 1023)
            value = 1023;
        world_analog(pin - ANALOG_FIRST, value);
        level = value >= 512;
    } else {
        level = value != 0;
        if (is_analog_pin)
            world_analog(pin - ANALOG_FIRST, level ? 1023 : 0);
    }
    if (pin < PINS)
        world_level(pin, level);
    world_changes++;
    return 0;
}

/* The firmware forwards SetInput (see the top of this file). */
static void gpior0_write(struct avr_t *a, avr_io_addr_t addr, uint8_t v, void *param)
{
    (void)addr; (void)param;
    if (!(v & SIM_GO))
        return;
    uint32_t value = a->data[REG_GPIOR2] | ((uint32_t)(v & 0x03) << 8);
    world_input(a->data[REG_GPIOR1], value, (v & SIM_ANALOG) != 0);
}

static void hook_world(int world)
{
    memset(ext_mask, 0, sizeof ext_mask);
    memset(ext_value, 0, sizeof ext_value);
    world_changes = 0;
    avr->vcc = avr->avcc = AVCC_MV;
    for (int ch = 0; ch < ANALOG_PINS; ch++)
        avr_raise_irq(avr_io_getirq(avr, AVR_IOCTL_ADC_GETIRQ, ch), analog_mv(ANALOG_DEFAULT));
    if (world) {
        avr->data[REG_GPIOR1] = SIM_MARK_1;
        avr->data[REG_GPIOR2] = SIM_MARK_2;
        avr_register_io_write(avr, REG_GPIOR0, gpior0_write, NULL);
    }
}

/* ------------------------------------------------------------------ UART */
#define TXQ 65536
static uint8_t txq_byte[TXQ];
static uint64_t txq_due[TXQ];     /* cycle at which the byte's last bit has left */
static uint32_t txq_head, txq_tail;
static uint64_t tx_line_free;     /* cycle at which the line is idle again */
static uint32_t tx_dropped;
#define RXQ 65536
static uint8_t rxq[RXQ];
static uint32_t rxq_head, rxq_tail;
static uint32_t rx_overruns;
static int uart_full;             /* simavr's receive FIFO said XOFF */
static avr_irq_t *uart_in;

static uint32_t cycles_per_byte(void)
{
    /* the chip's setting: UBRR0 and U2X0 (10 bits a character on the wire) */
    uint16_t ubrr = avr->data[0xC4] | ((avr->data[0xC5] & 0x0F) << 8);
    int u2x = (avr->data[0xC0] >> 1) & 1;
    return 10u * (ubrr + 1u) * (u2x ? 8u : 16u);
}

static void uart_out_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq; (void)param;
    /* the byte is on the wire once the shift register takes it; simavr paces the
     * writes, so each one starts when the line is free */
    uint64_t start = avr->cycle > tx_line_free ? avr->cycle : tx_line_free;
    uint64_t due = start + cycles_per_byte();
    tx_line_free = due;
    if (txq_head - txq_tail >= TXQ) {
        tx_dropped++;
        return;
    }
    txq_byte[txq_head % TXQ] = (uint8_t)value;
    txq_due[txq_head % TXQ] = due;
    txq_head++;
}

static void uart_xoff_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq; (void)param;
    uart_full = value != 0;
}

static void uart_xon_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq; (void)param;
    if (value)
        uart_full = 0;
}

static void rx_queue(const uint8_t *data, size_t n)
{
    for (size_t i = 0; i < n; i++) {
        if (rxq_head - rxq_tail >= RXQ) {
            rx_overruns++;
            continue;
        }
        rxq[rxq_head++ % RXQ] = data[i];
    }
}

/* hand queued bytes to the UART while its receive FIFO has room (it paces them) */
static void rx_feed(void)
{
    if (!((avr->data[REG_UCSR0B] >> RXEN0_BIT) & 1))
        return;  /* receiver off: the line waits (a board would lose them) */
    while (rxq_tail != rxq_head && !uart_full) {
        avr_raise_irq(uart_in, rxq[rxq_tail++ % RXQ]);
    }
}

static void hook_uart(void)
{
    uint32_t flags = 0;
    avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
    flags &= ~(AVR_UART_FLAG_STDIO | AVR_UART_FLAG_POLL_SLEEP);
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
                            uart_out_hook, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XOFF),
                            uart_xoff_hook, NULL);
    avr_irq_register_notify(avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUT_XON),
                            uart_xon_hook, NULL);
    uart_in = avr_io_getirq(avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
}

/* ------------------------------------------------------------------ running */
static avr_cycle_count_t stop_timer(struct avr_t *a, avr_cycle_count_t when, void *param)
{
    (void)a; (void)param;
    /* only ends a sleep at the right cycle.  It stays due every cycle after (the next
     * run cancels it): simavr processes every expired timer and then sleeps until the
     * next one, which would carry a sleeping chip past the cycle asked for. */
    return when + 1;
}

static uint64_t sleep_cycles;  /* the chip's idle time: 1 - sleep/total is its load */

static void sleep_hook(avr_t *a, avr_cycle_count_t how_long)
{
    (void)a;
    sleep_cycles += how_long + 1;  /* the core adds these; pacing is ours */
}

static int run_until(uint64_t until)
{
    if (avr->cycle >= until)
        return 0;
    avr_cycle_timer_cancel(avr, stop_timer, NULL);
    avr_cycle_timer_register(avr, until - avr->cycle, stop_timer, NULL);
    while (avr->cycle < until) {
        int state = avr_run(avr);
        if (state == cpu_Done || state == cpu_Crashed) {
            fprintf(stderr, "fas-simavr: the chip stopped (%s) at cycle %" PRIu64 "\n",
                    state == cpu_Done ? "sleeping with interrupts off" : "crashed",
                    avr->cycle);
            return -1;
        }
        rx_feed();
    }
    return 0;
}

static void logger(avr_t *a, const int level, const char *format, va_list ap)
{
    (void)a;
    if (level <= LOG_ERROR) {
        fputs("fas-simavr: ", stderr);
        vfprintf(stderr, format, ap);
    }
}


#ifndef FAS_SIMAVR_LIB
/* ------------------------------------------------------------------ pty */
static double wall_s(void)
{
    struct timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    return ts.tv_sec + ts.tv_nsec * 1e-9;
}

static volatile sig_atomic_t stopping;

static void on_signal(int sig)
{
    (void)sig;
    stopping = 1;
}

static int open_pty(char *path, size_t size, int *keep_slave)
{
    int master = posix_openpt(O_RDWR | O_NOCTTY);
    if (master < 0 || grantpt(master) || unlockpt(master))
        return -1;
    if (ptsname_r(master, path, size))
        return -1;
    /* one descriptor of the slave stays open here: hosts may come and go */
    int slave = open(path, O_RDWR | O_NOCTTY);
    if (slave < 0)
        return -1;
    struct termios tio;
    tcgetattr(slave, &tio);
    cfmakeraw(&tio);
    tcsetattr(slave, TCSANOW, &tio);
    *keep_slave = slave;
    fcntl(master, F_SETFL, fcntl(master, F_GETFL) | O_NONBLOCK);
    return master;
}

/* Lines "PIN VALUE [a]" on standard input: the world sets an input. */
static char cmd_buf[256];
static size_t cmd_len;
static int stdin_open = 1;

static void read_commands(void)
{
    if (!stdin_open)
        return;
    struct pollfd pfd = {.fd = 0, .events = POLLIN};
    while (poll(&pfd, 1, 0) > 0 && (pfd.revents & (POLLIN | POLLHUP))) {
        ssize_t r = read(0, cmd_buf + cmd_len, sizeof cmd_buf - 1 - cmd_len);
        if (r <= 0) {
            stdin_open = 0;
            return;
        }
        cmd_len += (size_t)r;
        char *nl;
        while ((nl = memchr(cmd_buf, '\n', cmd_len))) {
            *nl = 0;
            int pin;
            unsigned value;
            char kind = 'd';
            int n = sscanf(cmd_buf, "%d %u %c", &pin, &value, &kind);
            if ((n < 2 || world_input(pin, value, kind == 'a') != 0) && cmd_buf[0])
                fprintf(stderr, "fas-simavr: not an input: %s\n", cmd_buf);
            size_t used = (size_t)(nl - cmd_buf) + 1;
            memmove(cmd_buf, nl + 1, cmd_len - used);
            cmd_len -= used;
        }
        if (cmd_len == sizeof cmd_buf - 1)
            cmd_len = 0;  /* a line too long: dropped */
    }
}

static int serve_pty(double speed, const char *link, pid_t parent)
{
    char path[128];
    int slave = -1;
    int master = open_pty(path, sizeof path, &slave);
    if (master < 0) {
        perror("fas-simavr: pty");
        return 1;
    }
    if (link) {
        char tmp[4096];
        snprintf(tmp, sizeof tmp, "%s.tmp%d", link, (int)getpid());
        unlink(tmp);
        if (symlink(path, tmp) || rename(tmp, link))
            perror("fas-simavr: link");
    }
    printf("%s\n", path);
    fflush(stdout);
    signal(SIGINT, on_signal);
    signal(SIGTERM, on_signal);
    signal(SIGPIPE, SIG_IGN);

    double hz = (double)avr->frequency * speed;
    double t0 = wall_s();
    uint64_t c0 = avr->cycle;
    double behind_max = 0;
    int rc = 0;
    uint8_t buf[4096];
    /* whoever started us (stepperdemo device --simavr, a shell) going away ends the
     * run: killed outright, it cannot stop us, and an orphan would run for ever.
     * `parent` was taken before anything else (or named by --parent): read here, after
     * the path went out, a parent killed in between would already be gone unseen. */
    while (!stopping) {
        if (getppid() != parent)
            break;
        double now = wall_s();
        uint64_t target = c0 + (uint64_t)((now - t0) * hz);
        ssize_t r;
        read_commands();
        while ((r = read(master, buf, sizeof buf)) > 0)
            rx_queue(buf, (size_t)r);
        rx_feed();
        /* advance in slices, so that input is taken and output sent in good time */
        uint64_t slice = (uint64_t)(hz / 2000.0);  /* 0.5 ms */
        while (avr->cycle < target && !stopping) {
            uint64_t until = avr->cycle + slice < target ? avr->cycle + slice : target;
            if (run_until(until)) {
                rc = 1;
                stopping = 1;
                break;
            }
            while ((r = read(master, buf, sizeof buf)) > 0)
                rx_queue(buf, (size_t)r);
            rx_feed();
            size_t n = 0;
            while (txq_tail != txq_head && txq_due[txq_tail % TXQ] <= avr->cycle
                   && n < sizeof buf) {
                buf[n++] = txq_byte[txq_tail % TXQ];
                txq_tail++;
            }
            if (n) {
                ssize_t w = write(master, buf, n);
                /* nobody reads and the pty is full: the bytes are lost, as on a UART */
                if (w < (ssize_t)n)
                    tx_dropped += (uint32_t)(n - (w > 0 ? (size_t)w : 0));
            }
        }
        double behind = (wall_s() - t0) - (double)(avr->cycle - c0) / hz;
        if (behind > behind_max)
            behind_max = behind;
        /* wait for input or for the next slice */
        struct pollfd pfd = {.fd = master, .events = POLLIN};
        double ahead = (double)(avr->cycle - c0) / hz - (wall_s() - t0);
        int timeout_ms = ahead > 0.0005 ? (int)(ahead * 1000.0) : 0;
        if (timeout_ms > 0)
            poll(&pfd, 1, timeout_ms > 2 ? 2 : timeout_ms);
    }
    double wall = wall_s() - t0;
    if (trace)
        fflush(trace);
    fprintf(stdout, "simavr: %.3f s simulated in %.3f s wall (x%.2f), up to %.1f ms behind, "
            "chip busy %.1f %%\n",
            (double)(avr->cycle - c0) / avr->frequency, wall,
            wall > 0 ? (double)(avr->cycle - c0) / avr->frequency / wall : 0.0,
            behind_max * 1000.0,
            avr->cycle ? 100.0 * (1.0 - (double)sleep_cycles / (double)avr->cycle) : 0.0);
    for (int i = 0; i < PINS; i++)
        if (pins[i].rising || pins[i].falling)
            fprintf(stdout, "pin %d: %" PRIu32 " rising, %" PRIu32 " falling edges, now %d\n",
                    i, pins[i].rising, pins[i].falling, pins[i].level);
    if (world_changes)
        fprintf(stdout, "inputs set: %" PRIu32 "\n", world_changes);
    if (tx_dropped || rx_overruns)
        fprintf(stdout, "bytes lost: %" PRIu32 " sent to nobody, %" PRIu32 " received in excess\n",
                tx_dropped, rx_overruns);
    fflush(stdout);
    if (link) {
        char target[4096];
        ssize_t n = readlink(link, target, sizeof target - 1);
        if (n > 0) {
            target[n] = 0;
            if (!strcmp(target, path))
                unlink(link);
        }
    }
    close(slave);
    close(master);
    return rc;
}

#endif

/* ------------------------------------------------------------------ the chip */
/* Load the firmware into a fresh simulated chip.  EEPROM: the boot counter (so that
 * every run is a new boot for the host) and the clock rate per host second for a
 * chip run `speed` times faster than real time. */
static int chip_open(const char *elf, const char *mcu, uint32_t freq, const char *trace_file,
                     uint16_t boot_count, double speed, int world)
{
    memset(pins, 0, sizeof pins);
    memset(oc, 0, sizeof oc);
    tccr1a = 0;
    tccr2a = 0;
    oc2a = 0;
    timer2_prescaler = 0;
    timer1_start = 0;
    timer1_started = 0;
    txq_head = txq_tail = 0;
    tx_line_free = 0;
    tx_dropped = 0;
    rxq_head = rxq_tail = 0;
    rx_overruns = 0;
    uart_full = 0;
    sleep_cycles = 0;
    avr_global_logger_set(logger);
    elf_firmware_t fw;
    memset(&fw, 0, sizeof fw);
    if (elf_read_firmware(elf, &fw)) {
        fprintf(stderr, "fas-simavr: cannot read %s\n", elf);
        return -1;
    }
    avr = avr_make_mcu_by_name(mcu);
    if (!avr) {
        fprintf(stderr, "fas-simavr: unknown MCU %s\n", mcu);
        return -1;
    }
    avr_init(avr);
    avr->log = LOG_ERROR;
    avr->sleep = sleep_hook;
    fw.frequency = freq;
    strncpy(fw.mmcu, mcu, sizeof fw.mmcu - 1);
    avr_load_firmware(avr, &fw);
    avr->frequency = freq;
    uint32_t clock_hz = speed == 1.0 ? 0xFFFFFFFFu : (uint32_t)(freq * speed + 0.5);
    uint8_t ee[6] = {(uint8_t)boot_count, (uint8_t)(boot_count >> 8), (uint8_t)clock_hz,
                     (uint8_t)(clock_hz >> 8), (uint8_t)(clock_hz >> 16),
                     (uint8_t)(clock_hz >> 24)};
    avr_eeprom_desc_t desc = {.ee = ee, .offset = 0, .size = sizeof ee};
    avr_ioctl(avr, AVR_IOCTL_EEPROM_SET, &desc);
    trace = NULL;
    if (trace_file) {
        trace = fopen(trace_file, "w");
        if (!trace) {
            perror(trace_file);
            return -1;
        }
        setvbuf(trace, NULL, _IOFBF, 1 << 16);
        fprintf(trace, "# fas-simavr trace of %s\n# mcu %s, %" PRIu32 " Hz\n"
                "# columns: cycle pin level\n", elf, mcu, freq);
    }
    hook_pins();
    hook_uart();
    hook_world(world);
    return 0;
}

static void chip_close(void)
{
    if (trace) {
        fprintf(trace, "# end at cycle %" PRIu64 ", timer 1 started at cycle %" PRIu64 "\n",
                avr->cycle, timer1_start);
        fclose(trace);
        trace = NULL;
    }
    avr_terminate(avr);
    avr = NULL;
}

#ifdef FAS_SIMAVR_LIB
/* ------------------------------------------------------------------ library */
int fs_open(const char *elf, const char *trace_file, const char *mcu, uint32_t freq,
            uint16_t boot_count, int world)
{
    if (avr) {
        fprintf(stderr, "fas-simavr: one chip at a time\n");
        return -1;
    }
    return chip_open(elf, mcu, freq, trace_file, boot_count, 1.0, world);
}

/* The world sets input `pin` now (see the top of this file); -1: no such input. */
int fs_input(int pin, uint32_t value, int analog)
{
    return world_input(pin, value, analog);
}

/* The bytes in[0..n) reach the UART now; then run to `until`.  out: the bytes the chip
 * sent whose last bit has left by then (at most out_cap); state: cycle, cycle at which
 * the next queued byte will have left (0: none). */
int fs_run(uint64_t until, const uint8_t *in, uint32_t n, uint8_t *out, uint32_t out_cap,
           uint32_t *out_n, uint64_t *state)
{
    rx_queue(in, n);
    rx_feed();
    if (run_until(until))
        return -1;
    uint32_t m = 0;
    while (txq_tail != txq_head && txq_due[txq_tail % TXQ] <= avr->cycle && m < out_cap) {
        out[m++] = txq_byte[txq_tail % TXQ];
        txq_tail++;
    }
    *out_n = m;
    state[0] = avr->cycle;
    state[1] = txq_tail != txq_head ? txq_due[txq_tail % TXQ] : 0;
    return 0;
}

/* pins: per Arduino pin 0..19, level, rising and falling edges */
void fs_pins(uint8_t *level, uint32_t *rising, uint32_t *falling)
{
    for (int i = 0; i < PINS; i++) {
        level[i] = pins[i].level;
        rising[i] = pins[i].rising;
        falling[i] = pins[i].falling;
    }
}

/* cycle, timer-1 start cycle, frequency, cycles per character, bytes dropped, bytes
 * received in excess, cycles slept, bytes waiting for the UART */
void fs_info(uint64_t *v)
{
    v[7] = rxq_head - rxq_tail;
    v[0] = avr->cycle;
    v[1] = timer1_start;
    v[2] = avr->frequency;
    v[3] = cycles_per_byte();
    v[4] = tx_dropped;
    v[5] = rx_overruns;
    v[6] = sleep_cycles;
}

/* read (write = 0) or write the chip's data memory */
int fs_mem(uint16_t addr, uint16_t n, uint8_t *buf, int write)
{
    if ((uint32_t)addr + n > (uint32_t)avr->ramend + 1)
        return -1;
    if (write)
        memcpy(avr->data + addr, buf, n);
    else
        memcpy(buf, avr->data + addr, n);
    return 0;
}

void fs_flush_trace(void)
{
    if (trace)
        fflush(trace);
}

void fs_close(void)
{
    if (avr)
        chip_close();
}

#else
/* ------------------------------------------------------------------ main */
static void usage(void)
{
    fprintf(stderr,
            "usage: fas-simavr [--pty] [--link PATH] [--speed F] [--trace FILE] "
            "[--mcu NAME] [--freq HZ] [--boot N] [--parent PID] FIRMWARE.elf\n"
            "  --parent PID: end when PID is no longer our parent (default: the parent "
            "at start)\n"
            "  standard input: lines \"PIN VALUE\" (a level) or \"PIN VALUE a\" (an analog "
            "value 0..1023) set the board's inputs\n");
}

int main(int argc, char **argv)
{
    pid_t parent = getppid();
    const char *elf = NULL, *link = NULL, *mcu = "atmega328p", *trace_file = NULL;
    double speed = 1.0;
    uint32_t freq = 16000000;
    long boot = -1;
    for (int i = 1; i < argc; i++) {
        const char *a = argv[i];
        if (!strcmp(a, "--pty"))
            continue;
        else if (!strcmp(a, "--link") && i + 1 < argc)
            link = argv[++i];
        else if (!strcmp(a, "--speed") && i + 1 < argc)
            speed = atof(argv[++i]);
        else if (!strcmp(a, "--trace") && i + 1 < argc)
            trace_file = argv[++i];
        else if (!strcmp(a, "--mcu") && i + 1 < argc)
            mcu = argv[++i];
        else if (!strcmp(a, "--freq") && i + 1 < argc)
            freq = (uint32_t)strtoul(argv[++i], NULL, 10);
        else if (!strcmp(a, "--boot") && i + 1 < argc)
            boot = strtol(argv[++i], NULL, 10);
        else if (!strcmp(a, "--parent") && i + 1 < argc)
            parent = (pid_t)strtol(argv[++i], NULL, 10);
        else if (a[0] == '-') {
            usage();
            return 2;
        } else
            elf = a;
    }
    if (!elf || speed <= 0) {
        usage();
        return 2;
    }
    if (boot < 0) {  /* a new boot each run: the host sees a restarted device */
        struct timespec ts;
        clock_gettime(CLOCK_REALTIME, &ts);
        boot = (long)((ts.tv_nsec ^ ts.tv_sec ^ getpid()) & 0xFFFF);
    }
    if (chip_open(elf, mcu, freq, trace_file, (uint16_t)boot, speed, 1))
        return 2;
    int rc = serve_pty(speed, link, parent);
    chip_close();
    return rc;
}
#endif
