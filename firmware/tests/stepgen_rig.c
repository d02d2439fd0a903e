/* A test rig for the step generator alone (no protocol): the host side of the test
 * writes commands into `rig` through the simavr harness's memory access and runs the
 * chip until `done` equals `seq`.  Built by `make rig` (build/stepgen_rig.elf). */
#include <avr/interrupt.h>
#include <avr/io.h>

#include "../board.h"
#include "../limits.h"
#include "../stepgen.h"
#include "../ticks.h"

enum { RIG_ENTRY = 1, RIG_START_AT, RIG_START_NOW, RIG_STOP, RIG_DIR_PIN, RIG_PIN,
       RIG_DETACH, RIG_PCNT, RIG_SNAPSHOT, RIG_BLOCK, RIG_HALT };

struct rig {
    volatile uint8_t seq;   /* the host writes the command, then bumps seq */
    volatile uint8_t done;  /* the rig copies seq here when the command is done */
    uint8_t cmd;
    uint8_t ch;
    uint8_t arg;
    uint8_t arg2;
    uint32_t at;
    struct qentry entry;
    int16_t pcnt_low;
    int16_t pcnt_high;
    uint8_t late;           /* answer of RIG_START_AT */
    struct stepq_snapshot snap;  /* answer of RIG_SNAPSHOT */
    uint8_t hits;           /* limit stops the step generator made ... */
    uint8_t hit_ch;         /* ... the last one's queue and direction */
    uint8_t hit_up;
    uint32_t hit_tick;
};
struct rig rig __attribute__((used));
volatile uint8_t main_wake;  /* the firmware's main loop is not here: nobody looks */

/* The step generator stopped a queue at a closed limit (limits.c in the firmware):
 * here it is only counted, for the test to see. */
void limits_hit(uint8_t ch, uint8_t up)
{
    rig.hits++;
    rig.hit_ch = ch;
    rig.hit_up = up;
    rig.hit_tick = ticks_now();
}

static void execute(void)
{
    uint8_t ch = rig.ch;
    struct stepq *q = &stepq[ch];
    switch (rig.cmd) {
    case RIG_ENTRY:
        q->entry[q->wp & QUEUE_MASK] = rig.entry;
        stepgen_commit_entry(ch);
        break;
    case RIG_START_AT:
        rig.late = stepgen_start_at(ch, rig.at);
        break;
    case RIG_START_NOW:
        stepgen_start_now(ch);
        break;
    case RIG_STOP:
        stepgen_force_stop(ch);
        break;
    case RIG_DIR_PIN:
        stepgen_set_dir_pin(ch, rig.arg);
        break;
    case RIG_PIN:
        board_pin_write(rig.arg, rig.arg2);
        break;
    case RIG_DETACH:
        stepgen_set_detached(ch, rig.arg);
        break;
    case RIG_PCNT:
        stepgen_set_pcnt(ch, rig.arg, rig.pcnt_low, rig.pcnt_high, 0);
        break;
    case RIG_SNAPSHOT:
        stepgen_snapshot(ch, &rig.snap);
        break;
    case RIG_BLOCK: {
        /* a limit switch closes (arg: LB_* bits), as the pin-change interrupt does */
        cli();
        stepgen_set_block(ch, rig.arg);
        sei();
        break;
    }
    case RIG_HALT: {
        /* the limit stop of a running queue, as the pin-change interrupt makes it */
        cli();
        stepgen_halt_isr((uint8_t)(1u << ch));
        limits_hit(ch, rig.arg);
        sei();
        while (q->state)
            ;
        break;
    }
    }
}

int main(void)
{
    ticks_init();
    stepgen_init();
    sei();
    for (;;) {
        if (rig.seq != rig.done) {
            execute();
            rig.done = rig.seq;
        }
        stepgen_poll();
    }
}
