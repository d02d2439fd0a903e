/* Step generation on timer 1 (see stepgen.h).
 *
 * Each pulse takes two compare matches of its channel, both made by the hardware:
 * the first sets the pin (the step edge, exact to the tick), its interrupt switches
 * the channel to "clear on compare" with the compare a few ticks ahead and does the
 * queue's work; the second clears the pin and its interrupt programs the compare of
 * the next step.  A compare without a pulse (a pause, the wait after the last step)
 * is one interrupt with the channel disconnected from the pin.
 *
 * TIFR1 is never written: simavr 1.6 clears every flag of TIFR1 on any write to it
 * (the ATmega clears only the bits written as one), which would lose the other
 * channel's compare or the overflow of the tick counter.  The compare interrupts stay
 * enabled, so every match is taken by its interrupt (an idle channel's are ignored);
 * simavr would not run an interrupt for a flag raised while it was disabled.
 */
#include <avr/interrupt.h>
#include <avr/io.h>

#include "board.h"
#include "irq.h"
#include "limits.h"
#include "stepgen.h"
#include "ticks.h"
#include "uart.h"

struct stepq stepq[FW_MAX_STEPPERS];

/* The pulse counter (the API's attachToPulseCounter): counts by the direction pin
 * level, back to 0 at a limit (both limits 0: wraps as int16). */
static inline __attribute__((always_inline)) void pcnt_count(struct stepq *q, uint8_t flags)
{
    uint8_t pf = q->pcnt_flags;
    uint8_t up = ((flags & QE_DIR_LEVEL) != 0) == ((pf & PCNT_DIR_HIGH_UP) != 0);
    int16_t v;
    if (up) {
        v = (int16_t)((uint16_t)q->pcnt + 1u);
        if (q->pcnt_high > 0 && v >= q->pcnt_high)
            v = 0;
    } else {
        v = (int16_t)((uint16_t)q->pcnt - 1u);
        if (q->pcnt_low < 0 && v <= q->pcnt_low)
            v = 0;
    }
    q->pcnt = v;
}

/* compare output modes in TCCR1A */
#define COM_MASK_A (_BV(COM1A1) | _BV(COM1A0))
#define COM_SET_A (_BV(COM1A1) | _BV(COM1A0))   /* set the pin on compare match */
#define COM_CLEAR_A _BV(COM1A1)                 /* clear the pin on compare match */
#define COM_MASK_B (_BV(COM1B1) | _BV(COM1B0))
#define COM_SET_B (_BV(COM1B1) | _BV(COM1B0))
#define COM_CLEAR_B _BV(COM1B1)

/* The clearing compare is set this many ticks after reading the counter: the write
 * of the compare register must be complete before the counter gets there. */
#define CLEAR_LEAD 12
/* startQueue: the first compare this many ticks after the start */
#define START_TICKS 10
/* the step interrupt's "at once" delay for an entry that came after the queue ran dry */
#define RESTART_TICKS 10
/* a timed start whose compare is closer than this to now (or to a counter wrap) is
 * begun by waiting in the main loop instead */
#define START_ARM_MIN 160

/* a C constant in the assembly text */
#define K_(x) #x
#define K(x) K_(x)

#define SET_COM(X, mode) TCCR1A = (uint8_t)((TCCR1A & ~COM_MASK_##X) | (mode))

static inline __attribute__((always_inline)) void count_pulse(struct stepq *q, uint8_t flags)
{
    /* 16-bit counts here; the main loop folds them into the 32-bit figures */
    if (flags & QE_COUNT_UP)
        q->pulses_up++;
    else
        q->pulses_down++;
    if (q->pcnt_flags & PCNT_ON)
        pcnt_count(q, flags);
}

/* Where toggles of a stepper without a direction pin go (never a null pointer for
 * the interrupt to check). */
static volatile uint8_t no_dir_pin;

static inline __attribute__((always_inline)) void toggle_dir(struct stepq *q)
{
    *q->dir_reg = q->dir_mask;  /* writing a one to PINx toggles the pin */
}

/* The state of a queue that begins; toggles the direction pin if its first entry
 * says so (FastAccelStepper's startQueue). */
static inline __attribute__((always_inline)) uint8_t first_state(struct stepq *q)
{
    struct qentry *e = &q->entry[q->rp & QUEUE_MASK];
    if (e->flags & QE_TOGGLE_DIR)
        toggle_dir(q);
    return (uint8_t)(SQ_RUNNING | (e->steps ? SQ_ARMED : 0));
}

/* The entry at the read index would step towards a closed limit switch: LB_* (0: no). */
static inline __attribute__((always_inline)) uint8_t first_blocked(struct stepq *q)
{
    struct qentry *e = &q->entry[q->rp & QUEUE_MASK];
    return e->steps ? (uint8_t)(q->limit_block & BLOCK_BIT(e->flags)) : 0;
}

/* Connect channel X for its first compare: at `compare`, or START_TICKS from now.
 * Interrupts are off and the channel's flag is clear. */
#define ARM(X, q, compare, st, from_now)                                         \
    do {                                                                         \
        SET_COM(X, (((st) & SQ_ARMED) && !(q)->detached) ? COM_SET_##X : 0);     \
        if (from_now)                                                            \
            OCR1##X = TCNT1 + START_TICKS;                                       \
        else                                                                     \
            OCR1##X = (compare);                                                 \
        (q)->state = (st);                                                       \
    } while (0)

/* A timed start waits: the compare register holds the start tick's low 16 bits and
 * matches once per counter wrap; `start_wraps` counts the matches still to come
 * before the start.  At the last of them the channel is armed, so that the start
 * tick's compare makes the first pulse. */
#define PENDING_COMPARE(X, CH)                                                   \
    static inline __attribute__((always_inline)) void                           \
    pending_compare_##X(struct stepq *q)                                         \
    {                                                                            \
        if (--q->start_wraps)                                                    \
            return;                                                              \
        if (q->rp == q->wp) {                                                    \
            q->state = 0; /* emptied meanwhile */                                \
            return;                                                              \
        }                                                                        \
        uint8_t st = first_state(q);                                             \
        uint8_t blocked = first_blocked(q);                                      \
        if (blocked) {                                                           \
            /* it would start towards a closed limit switch */                   \
            q->state = 0;                                                        \
            limits_hit(CH, blocked == LB_UP);                                    \
            return;                                                              \
        }                                                                        \
        SET_COM(X, ((st & SQ_ARMED) && !q->detached) ? COM_SET_##X : 0);         \
        q->state = st;                                                           \
    }

/* The compare interrupt of channel X (queue CH), all of it: FastAccelStepper's step
 * interrupt with the pulse's falling edge made by a second compare (see the top of
 * this file).  A compare that raised the pin sets up the falling edge, does the
 * queue's work and leaves the next compare to the falling edge's interrupt; a
 * compare without a pulse programs the next one at once.  A direction toggle waits
 * for the falling edge (never during a pulse).  The dispatcher below (assembly) does
 * the frequent cases itself and comes here for the others: a timed start that
 * waits, a stop, a detached step pin, a pulse counter, an idle channel. */
#define STEP_ISR_FULL(X, CH)                                                     \
    void __vector_stepgen_full_##X(void) __attribute__((signal, used, externally_visible)); \
    void __vector_stepgen_full_##X(void)                                                  \
    {                                                                            \
        struct stepq *q = &stepq[CH];                                            \
        uint8_t st = q->state;                                                   \
        if (st & SQ_PENDING) {                                                   \
            pending_compare_##X(q);                                              \
            return;                                                              \
        }                                                                        \
        if (!(st & SQ_RUNNING)) {                                                \
            /* an idle channel's match (every counter wrap), or one that was     \
             * pending while a start was set up (SQ_FLUSH) */                    \
            q->state = 0;                                                        \
            return;                                                              \
        }                                                                        \
        if (st & SQ_FALLING) {                                                   \
            /* the pin went low: the next compare */                             \
            if (st & SQ_STOPPING) {                                              \
                if (st & SQ_TOGGLE) /* the entry that began says so (the model) */ \
                    toggle_dir(q);                                               \
                SET_COM(X, 0);                                                   \
                q->state = 0;                                                    \
                main_wake |= WAKE_IDLE;                                          \
                return;                                                          \
            }                                                                    \
            if (st & SQ_TOGGLE)                                                  \
                toggle_dir(q);                                                   \
            SET_COM(X, q->next_com);                                             \
            OCR1##X = q->next_compare;                                           \
            q->state = (uint8_t)(st & ~(SQ_FALLING | SQ_TOGGLE));                \
            return;                                                              \
        }                                                                        \
        uint16_t base = OCR1##X;                                                 \
        uint8_t pulse = 0;                                                       \
        if ((TCCR1A & COM_MASK_##X) == COM_SET_##X) {                            \
            /* the pin went high: take it low with a compare a few ticks on */   \
            SET_COM(X, COM_CLEAR_##X);                                           \
            OCR1##X = TCNT1 + CLEAR_LEAD;                                        \
            pulse = 1;                                                           \
        }                                                                        \
        uint8_t rp = q->rp;                                                      \
        struct qentry *e = &q->entry[rp & QUEUE_MASK];                           \
        if (st & SQ_ARMED)                                                       \
            count_pulse(q, e->flags);                                            \
        uint8_t wp = q->wp;                                                      \
        if ((st & SQ_STOPPING) || rp == wp) {                                    \
            if (pulse) {                                                         \
                q->state = SQ_RUNNING | SQ_FALLING | SQ_STOPPING;                \
            } else {                                                             \
                SET_COM(X, 0);                                                   \
                q->state = 0;                                                    \
                main_wake |= WAKE_IDLE;                                          \
            }                                                                    \
            return;                                                              \
        }                                                                        \
        uint16_t ticks = e->ticks;                                               \
        if (e->steps > 1) {                                                      \
            e->steps--;                                                          \
            st |= SQ_ARMED;                                                      \
        } else {                                                                 \
            if (st & SQ_NO_MORE) {                                               \
                st &= (uint8_t)~SQ_NO_MORE;                                      \
                if (e->steps != 0)                                               \
                    ticks = RESTART_TICKS;                                       \
            } else {                                                             \
                rp++;                                                            \
                q->rp = rp;                                                      \
                if (rp == wp) {                                                  \
                    /* the queue ran dry: wait out this period, then stop */     \
                    st = (uint8_t)((st | SQ_NO_MORE) & ~SQ_ARMED);               \
                    goto program;                                                \
                }                                                                \
                e = &q->entry[rp & QUEUE_MASK];                                  \
            }                                                                    \
            if (e->steps != 0)                                                   \
                st |= SQ_ARMED;                                                  \
            else                                                                 \
                st &= (uint8_t)~SQ_ARMED;                                        \
            if (e->flags & QE_TOGGLE_DIR) {                                      \
                if (pulse)                                                       \
                    st |= SQ_TOGGLE;                                             \
                else                                                             \
                    toggle_dir(q);                                               \
            }                                                                    \
            if (e->steps && (q->limit_block & BLOCK_BIT(e->flags))) {            \
                /* the entry steps towards a closed limit switch: not one pulse */ \
                limits_hit(CH, (e->flags & QE_COUNT_UP) != 0);                   \
                if (pulse) {                                                     \
                    q->state = (uint8_t)(SQ_RUNNING | SQ_FALLING | SQ_STOPPING   \
                                         | (st & SQ_TOGGLE));                    \
                } else {                                                         \
                    SET_COM(X, 0);                                               \
                    q->state = 0;                                                \
                    main_wake |= WAKE_IDLE;                                      \
                }                                                                \
                return;                                                          \
            }                                                                    \
        }                                                                        \
    program:;                                                                    \
        uint8_t com = ((st & SQ_ARMED) && !q->detached) ? COM_SET_##X : 0;       \
        if (pulse) {                                                             \
            q->next_compare = base + ticks;                                      \
            q->next_com = com;                                                   \
            q->state = st | SQ_FALLING;                                          \
        } else {                                                                 \
            SET_COM(X, com);                                                     \
            OCR1##X = base + ticks;                                              \
            q->state = st;                                                       \
        }                                                                        \
    }

/* Z = &entry[r19 & QUEUE_MASK] of queue CH (4 bytes an entry) */
#define ENTRY_Z                                                                  \
    "mov r30, r19\n\t"                                                           \
    "andi r30, " K(QUEUE_MASK) "\n\t"                                            \
    "ldi r31, 0\n\t"                                                             \
    "lsl r30\n\t"                                                                \
    "rol r31\n\t"                                                                \
    "lsl r30\n\t"                                                                \
    "rol r31\n\t"                                                                \
    "subi r30, lo8(-(%[entry]))\n\t"                                             \
    "sbci r31, hi8(-(%[entry]))\n\t"

/* The dispatcher, the vector itself, in assembly: what __vector_stepgen_full_X does for a
 * running channel without pulse counter or detached pin and without a stop - the
 * rising edge with the queue's work, a compare without a pulse, the falling edge.
 * Everything else goes to __vector_stepgen_full_X with the registers as they were.  The T
 * flag says whether this compare put a pulse on the pin. */
#define STEP_ISR(X, CH)                                                          \
    ISR(TIMER1_COMP##X##_vect, ISR_NAKED)                                        \
    {                                                                            \
        __asm__ __volatile__(                                                    \
            "push r24\n\t"                                                       \
            "in r24, __SREG__\n\t"                                               \
            "push r24\n\t"                                                       \
            "push r25\n\t"                                                       \
            "lds r24, %[state]\n\t"                                              \
            "sbrc r24, " K(SQ_FALLING_BIT) "\n\t"                                \
            "rjmp 3f\n\t"                                                        \
            "mov r25, r24\n\t"                                                   \
            "andi r25, lo8(~(" K(SQ_RUNNING | SQ_ARMED | SQ_NO_MORE) "))\n\t"      \
            "brne 8f\n\t"                                                        \
            "sbrs r24, " K(SQ_RUNNING_BIT) "\n\t"                                \
            "rjmp 8f\n\t"                                                        \
            "lds r25, %[slow]\n\t"                                               \
            "tst r25\n\t"                                                        \
            "breq 1f\n"                                                          \
            "8:\n\t"                                                             \
            "pop r25\n\t"                                                        \
            "pop r24\n\t"                                                        \
            "out __SREG__, r24\n\t"                                              \
            "pop r24\n\t"                                                        \
            "jmp __vector_stepgen_full_" #X "\n"                                          \
            "3:\n\t"                                                             \
            /* the falling edge: toggle if asked, then the next compare */       \
            "sbrc r24, " K(SQ_STOPPING_BIT) "\n\t"                               \
            "rjmp 8b\n\t"                                                        \
            "sbrs r24, " K(SQ_TOGGLE_BIT) "\n\t"                                 \
            "rjmp 4f\n\t"                                                        \
            "push r30\n\t"                                                       \
            "push r31\n\t"                                                       \
            "lds r30, %[dir_reg]\n\t"                                            \
            "lds r31, %[dir_reg]+1\n\t"                                          \
            "lds r25, %[dir_mask]\n\t"                                           \
            "st Z, r25\n\t"                                                      \
            "pop r31\n\t"                                                        \
            "pop r30\n"                                                          \
            "4:\n\t"                                                             \
            "andi r24, lo8(~(" K(SQ_FALLING | SQ_TOGGLE) "))\n\t"                  \
            "sts %[state], r24\n\t"                                              \
            "lds r24, %[tccr1a]\n\t"                                             \
            "andi r24, lo8(~(" K(COM_MASK_##X) "))\n\t"                            \
            "lds r25, %[next_com]\n\t"                                           \
            "or r24, r25\n\t"                                                    \
            "sts %[tccr1a], r24\n\t"                                             \
            "lds r24, %[next_compare]\n\t"                                       \
            "lds r25, %[next_compare]+1\n\t"                                     \
            "sts %[ocr]+1, r25\n\t"                                              \
            "sts %[ocr], r24\n\t"                                                \
            "rjmp 9f\n"                                                          \
            "1:\n\t"                                                             \
            /* a step compare: r18 state, r19 rp, r22:r23 base, then next */     \
            "push r18\n\t"                                                       \
            "push r19\n\t"                                                       \
            "push r22\n\t"                                                       \
            "push r23\n\t"                                                       \
            "push r30\n\t"                                                       \
            "push r31\n\t"                                                       \
            "mov r18, r24\n\t"                                                   \
            "lds r22, %[ocr]\n\t"                                                \
            "lds r23, %[ocr]+1\n\t"                                              \
            "clt\n\t"                                                            \
            "sbrs r18, " K(SQ_ARMED_BIT) "\n\t"                                  \
            "rjmp 1f\n\t"                                                        \
            /* the pin went high: clear it with a compare CLEAR_LEAD ticks on */ \
            "set\n\t"                                                            \
            "lds r24, %[tccr1a]\n\t"                                             \
            "andi r24, lo8(~(" K(COM_MASK_##X) "))\n\t"                            \
            "ori r24, " K(COM_CLEAR_##X) "\n\t"                                  \
            "sts %[tccr1a], r24\n\t"                                             \
            "lds r24, %[tcnt]\n\t"                                               \
            "lds r25, %[tcnt]+1\n\t"                                             \
            "adiw r24, " K(CLEAR_LEAD) "\n\t"                                    \
            "sts %[ocr]+1, r25\n\t"                                              \
            "sts %[ocr], r24\n"                                                  \
            "1:\n\t"                                                             \
            "lds r19, %[rp]\n\t"                                                 \
            ENTRY_Z                                                              \
            /* count the pulse made */                                           \
            "sbrs r18, " K(SQ_ARMED_BIT) "\n\t"                                  \
            "rjmp 1f\n\t"                                                        \
            "ldd r24, Z+1\n\t"                                                   \
            "sbrs r24, " K(QE_COUNT_UP_BIT) "\n\t"                               \
            "rjmp 2f\n\t"                                                        \
            "lds r24, %[up]\n\t"                                                 \
            "lds r25, %[up]+1\n\t"                                               \
            "adiw r24, 1\n\t"                                                    \
            "sts %[up]+1, r25\n\t"                                               \
            "sts %[up], r24\n\t"                                                 \
            "rjmp 1f\n"                                                          \
            "2:\n\t"                                                             \
            "lds r24, %[down]\n\t"                                               \
            "lds r25, %[down]+1\n\t"                                             \
            "adiw r24, 1\n\t"                                                    \
            "sts %[down]+1, r25\n\t"                                             \
            "sts %[down], r24\n"                                                 \
            "1:\n\t"                                                             \
            "lds r24, %[wp]\n\t"                                                 \
            "cp r19, r24\n\t"                                                    \
            "brne 1f\n\t"                                                        \
            /* an empty queue: stop (after the falling edge of a pulse) */       \
            "brts 2f\n\t"                                                        \
            "lds r24, %[tccr1a]\n\t"                                             \
            "andi r24, lo8(~(" K(COM_MASK_##X) "))\n\t"                            \
            "sts %[tccr1a], r24\n\t"                                             \
            "sts %[state], __zero_reg__\n\t"                                     \
            "lds r24, %[wake]\n\t"                                              \
            "ori r24, " K(WAKE_IDLE) "\n\t"                                     \
            "sts %[wake], r24\n\t"                                              \
            "rjmp 7f\n"                                                          \
            "2:\n\t"                                                             \
            "ldi r24, " K(SQ_RUNNING | SQ_FALLING | SQ_STOPPING) "\n\t"          \
            "sts %[state], r24\n\t"                                              \
            "rjmp 7f\n"                                                          \
            "1:\n\t"                                                             \
            "ld r24, Z\n\t"                                                      \
            "cpi r24, 2\n\t"                                                     \
            "brlo 1f\n\t"                                                        \
            /* another step of this entry, one period on */                      \
            "dec r24\n\t"                                                        \
            "st Z, r24\n\t"                                                      \
            "ori r18, " K(SQ_ARMED) "\n\t"                                       \
            "ldd r24, Z+2\n\t"                                                   \
            "ldd r25, Z+3\n\t"                                                   \
            "add r22, r24\n\t"                                                   \
            "adc r23, r25\n\t"                                                   \
            "rjmp 6f\n"                                                          \
            "1:\n\t"                                                             \
            "sbrs r18, " K(SQ_NO_MORE_BIT) "\n\t"                                \
            "rjmp 2f\n\t"                                                        \
            /* an entry came after the queue ran dry: begins at once */          \
            "andi r18, lo8(~(" K(SQ_NO_MORE) "))\n\t"                              \
            "tst r24\n\t"                                                        \
            "breq 1f\n\t"                                                        \
            "subi r22, lo8(-(" K(RESTART_TICKS) "))\n\t"                         \
            "sbci r23, hi8(-(" K(RESTART_TICKS) "))\n\t"                         \
            "rjmp 4f\n"                                                          \
            "1:\n\t"                                                             \
            "ldd r24, Z+2\n\t"                                                   \
            "ldd r25, Z+3\n\t"                                                   \
            "add r22, r24\n\t"                                                   \
            "adc r23, r25\n\t"                                                   \
            "rjmp 4f\n"                                                          \
            "2:\n\t"                                                             \
            /* the entry is done: its last period, then the next entry */        \
            "ldd r24, Z+2\n\t"                                                   \
            "ldd r25, Z+3\n\t"                                                   \
            "add r22, r24\n\t"                                                   \
            "adc r23, r25\n\t"                                                   \
            "inc r19\n\t"                                                        \
            "sts %[rp], r19\n\t"                                                 \
            "lds r24, %[wp]\n\t"                                                 \
            "cp r19, r24\n\t"                                                    \
            "brne 1f\n\t"                                                        \
            "ori r18, " K(SQ_NO_MORE) "\n\t"                                     \
            "andi r18, lo8(~(" K(SQ_ARMED) "))\n\t"                                \
            "rjmp 6f\n"                                                          \
            "1:\n\t"                                                             \
            ENTRY_Z                                                              \
            "4:\n\t"                                                             \
            /* the entry begins: armed if it has steps; direction toggle */      \
            "andi r18, lo8(~(" K(SQ_ARMED) "))\n\t"                                \
            "ld r24, Z\n\t"                                                      \
            "tst r24\n\t"                                                        \
            "breq 1f\n\t"                                                        \
            "ori r18, " K(SQ_ARMED) "\n"                                         \
            "1:\n\t"                                                             \
            "ldd r24, Z+1\n\t"                                                   \
            "sbrs r24, " K(QE_TOGGLE_DIR_BIT) "\n\t"                             \
            "rjmp 6f\n\t"                                                        \
            "brtc 1f\n\t"                                                        \
            "ori r18, " K(SQ_TOGGLE) "\n\t" /* after the falling edge */        \
            "rjmp 6f\n"                                                          \
            "1:\n\t"                                                             \
            "lds r30, %[dir_reg]\n\t"                                            \
            "lds r31, %[dir_reg]+1\n\t"                                          \
            "lds r24, %[dir_mask]\n\t"                                           \
            "st Z, r24\n"                                                        \
            "6:\n\t"                                                             \
            /* the next compare at r22:r23 */                                    \
            "brtc 1f\n\t"                                                        \
            "sts %[next_compare], r22\n\t"                                       \
            "sts %[next_compare]+1, r23\n\t"                                     \
            "ldi r24, 0\n\t"                                                     \
            "sbrc r18, " K(SQ_ARMED_BIT) "\n\t"                                  \
            "ldi r24, " K(COM_SET_##X) "\n\t"                                    \
            "sts %[next_com], r24\n\t"                                           \
            "ori r18, " K(SQ_FALLING) "\n\t"                                     \
            "sts %[state], r18\n\t"                                              \
            "rjmp 7f\n"                                                          \
            "1:\n\t"                                                             \
            "lds r24, %[tccr1a]\n\t"                                             \
            "andi r24, lo8(~(" K(COM_MASK_##X) "))\n\t"                            \
            "sbrc r18, " K(SQ_ARMED_BIT) "\n\t"                                  \
            "ori r24, " K(COM_SET_##X) "\n\t"                                    \
            "sts %[tccr1a], r24\n\t"                                             \
            "sts %[ocr]+1, r23\n\t"                                              \
            "sts %[ocr], r22\n\t"                                                \
            "sts %[state], r18\n"                                                \
            "7:\n\t"                                                             \
            "pop r31\n\t"                                                        \
            "pop r30\n\t"                                                        \
            "pop r23\n\t"                                                        \
            "pop r22\n\t"                                                        \
            "pop r19\n\t"                                                        \
            "pop r18\n"                                                          \
            "9:\n\t"                                                             \
            "pop r25\n\t"                                                        \
            "pop r24\n\t"                                                        \
            "out __SREG__, r24\n\t"                                              \
            "pop r24\n\t"                                                        \
            "reti\n\t"                                                           \
            ::[state] "i"(&stepq[CH].state), [rp] "i"(&stepq[CH].rp),           \
              [wp] "i"(&stepq[CH].wp), [entry] "i"(&stepq[CH].entry[0]),         \
              [up] "i"(&stepq[CH].pulses_up), [down] "i"(&stepq[CH].pulses_down), \
              [next_compare] "i"(&stepq[CH].next_compare),                       \
              [next_com] "i"(&stepq[CH].next_com), [slow] "i"(&stepq[CH].slow), \
              [dir_reg] "i"(&stepq[CH].dir_reg), [dir_mask] "i"(&stepq[CH].dir_mask), \
              [tccr1a] "i"(_SFR_MEM_ADDR(TCCR1A)), [tcnt] "i"(_SFR_MEM_ADDR(TCNT1)), \
              [ocr] "i"(_SFR_MEM_ADDR(OCR1##X)), \
              [wake] "i"(&main_wake));                                           \
    }

PENDING_COMPARE(A, 0)
PENDING_COMPARE(B, 1)
STEP_ISR_FULL(A, 0)
STEP_ISR_FULL(B, 1)
STEP_ISR(A, 0)
STEP_ISR(B, 1)

void stepgen_init(void)
{
    /* step pins: outputs, low; the compare unit drives them while connected */
    PORTB &= (uint8_t)~(_BV(PB1) | _BV(PB2));
    DDRB |= _BV(PB1) | _BV(PB2);
    for (uint8_t ch = 0; ch < FW_MAX_STEPPERS; ch++) {
        stepq[ch].dir_reg = &no_dir_pin;
        stepq[ch].state = 0;
    }
    /* the compare interrupts stay enabled: an idle channel's match (once per counter
     * wrap) finds state 0 and returns, so no match flag is ever left stale */
    TIMSK1 |= _BV(OCIE1A) | _BV(OCIE1B);
}

/* With interrupts off: put the channel's compare far ahead and let a match that
 * came just before (its interrupt pending: the compare interrupts stay enabled, an
 * idle channel's matches are taken and ignored) run first, never by writing TIFR1
 * (see the top). */
static void prepare(uint8_t ch)
{
    struct stepq *q = &stepq[ch];
    uint8_t flag = ch == 0 ? _BV(OCF1A) : _BV(OCF1B);
    if (ch == 0)
        OCR1A = TCNT1 + 0x8000u;
    else
        OCR1B = TCNT1 + 0x8000u;
    if (TIFR1 & flag) {
        q->state = SQ_FLUSH;
        irq_on();
        while (q->state == SQ_FLUSH)
            ;
        cli();
    }
}

static void arm_at(uint8_t ch, uint16_t compare, uint8_t st, uint8_t from_now)
{
    struct stepq *q = &stepq[ch];
    if (ch == 0)
        ARM(A, q, compare, st, from_now);
    else
        ARM(B, q, compare, st, from_now);
}

/* A start towards a closed limit switch does not begin (the entry's direction
 * toggle is made, as at any start); interrupts are off. */
static inline __attribute__((always_inline)) uint8_t start_blocked(uint8_t ch)
{
    struct stepq *q = &stepq[ch];
    if (!q->limit_block)
        return 0;  /* no switch closed: the common case, at once */
    uint8_t blocked = first_blocked(q);
    if (blocked) {
        first_state(q);
        limits_hit(ch, blocked == LB_UP);
    }
    return blocked;
}

/* Note the tick of the first compare of a start for the Started report. */
static void note_start(uint8_t ch, uint32_t tick)
{
    stepq[ch].start_tick = tick;
    stepq[ch].started = 1;
}

void stepgen_start_now(uint8_t ch)
{
    struct stepq *q = &stepq[ch];
    uint8_t sreg = irq_save();
    if (!(q->state & (SQ_RUNNING | SQ_PENDING)) && q->rp != q->wp && !q->limit_hit) {
        prepare(ch);
        if (!start_blocked(ch)) {
            arm_at(ch, 0, first_state(q), 1);
            uint16_t compare = ch == 0 ? OCR1A : OCR1B;
            uint32_t now = ticks_now();
            note_start(ch, now + (int16_t)(compare - (uint16_t)now));
        }
    }
    irq_restore(sreg);
}

/* How a start was armed: its first compare at the start tick, or "now". */
#define ARMED_AT 1
#define ARMED_NOW 2

uint8_t stepgen_start_at(uint8_t ch, uint32_t at)
{
    struct stepq *q = &stepq[ch];
    uint32_t compare = at + START_TICKS;
    uint8_t sreg = SREG;
    uint8_t late = 0, armed = 0, check = 1;
    for (;;) {
        cli();
        if (q->state & SQ_PENDING)
            q->state = 0;  /* a new start replaces the one that waits */
        if ((q->state & SQ_RUNNING) || q->rp == q->wp || q->limit_hit)
            break;
        prepare(ch);  /* (may let a pending interrupt run: a switch may close there) */
        if (check && start_blocked(ch))
            break;
        check = 0;
        uint32_t now = ticks_now();
        int32_t ahead = (int32_t)(compare - now);
        uint16_t first_match = (uint16_t)ahead;  /* ticks to the next match of compare */
        if (ahead >= START_ARM_MIN && ahead < 65536L - START_ARM_MIN) {
            arm_at(ch, (uint16_t)compare, first_state(q), 0);
            armed = ARMED_AT;
            break;
        }
        if (ahead >= 65536L && first_match >= START_ARM_MIN
                && first_match < 65536u - START_ARM_MIN) {
            /* it matches every wrap: `ahead >> 16` times before the start */
            q->start_wraps = (uint16_t)((uint32_t)ahead >> 16);
            arm_at(ch, (uint16_t)compare, SQ_PENDING, 0);
            armed = ARMED_AT;
            break;
        }
        int32_t until = (int32_t)(at - now);
        if (until <= 0) {
            late = until < 0;
            arm_at(ch, 0, first_state(q), 1);
            armed = ARMED_NOW;
            break;
        }
        /* the first match would come too close to now: wait a few microseconds with
         * interrupts on (a limit switch may close meanwhile: checked again) */
        irq_on();
        check = 1;
    }
    if (armed == ARMED_NOW) {
        uint16_t ocr = ch == 0 ? OCR1A : OCR1B;
        uint32_t now = ticks_now();
        compare = now + (int16_t)(ocr - (uint16_t)now);
    }
    irq_restore(sreg);
    if (armed)
        note_start(ch, compare);
    return late;
}

void stepgen_force_stop(uint8_t ch)
{
    struct stepq *q = &stepq[ch];
    uint8_t sreg = irq_save();
    uint8_t st = q->state;
    if (st & SQ_PENDING) {
        q->state = 0;
    } else if (st & SQ_RUNNING) {
        uint8_t flag = ch == 0 ? _BV(OCF1A) : _BV(OCF1B);
        uint16_t to_compare = ch == 0 ? OCR1A - TCNT1 : OCR1B - TCNT1;
        if ((st & SQ_FALLING) || ((st & SQ_ARMED) && ((TIFR1 & flag) || to_compare < 64u))) {
            /* a pulse is on the pin or about to be: the interrupts finish it, count
             * it and stop */
            q->state = st | SQ_STOPPING;
            irq_on();
            while (q->state)
                ;
            cli();
        } else {
            /* the coming compare is far enough (or makes no pulse): nothing happens
             * on the pin any more */
            if (ch == 0)
                SET_COM(A, 0);
            else
                SET_COM(B, 0);
            q->state = 0;
        }
    }
    irq_restore(sreg);
}

/* Fold the interrupt's 16-bit pulse counts into the 32-bit figures: only taking
 * them is done with interrupts off (short sections keep the step latency low). */
static void fold(struct stepq *q)
{
    uint8_t sreg = irq_save();
    uint16_t up = q->pulses_up, down = q->pulses_down;
    q->pulses_up = 0;
    q->pulses_down = 0;
    irq_restore(sreg);
    q->pulses += (uint32_t)up + down;
    q->pulse_pos += (int32_t)up - (int32_t)down;
}

void stepgen_snapshot(uint8_t ch, struct stepq_snapshot *s)
{
    struct stepq *q = &stepq[ch];
    fold(q);
    uint8_t sreg = irq_save();
    s->state = q->state;
    s->rp = q->rp;
    s->steps = q->entry[q->rp & QUEUE_MASK].steps;
    s->pulses = q->pulses;
    s->pulse_pos = q->pulse_pos;
    s->pcnt = q->pcnt;
    irq_restore(sreg);
}

void stepgen_poll(void)
{
    for (uint8_t ch = 0; ch < FW_MAX_STEPPERS; ch++)
        fold(&stepq[ch]);
}

void stepgen_set_counts(uint8_t ch, uint32_t pulses, int32_t pulse_pos)
{
    struct stepq *q = &stepq[ch];
    fold(q);
    q->pulses = pulses;
    q->pulse_pos = pulse_pos;
}

void stepgen_set_dir_pin(uint8_t ch, uint8_t pin)
{
    struct stepq *q = &stepq[ch];
    volatile uint8_t *reg = &no_dir_pin;
    uint8_t mask = 0;
    uint8_t real = pin != PIN_NONE && !(pin & PIN_EXTERNAL) && board_pin_usable(pin);
    if (real) {
        reg = board_pin_reg(pin);
        mask = board_pin_mask(pin);
    }
    uint8_t sreg = irq_save();
    q->dir_reg = reg;
    q->dir_mask = mask;
    if (real)
        reg[1] |= mask;  /* an output (its level stays as written) */
    irq_restore(sreg);
}

static void update_slow(struct stepq *q)
{
    q->slow = q->detached | (q->pcnt_flags & PCNT_ON) | q->limit_block;
}

void stepgen_forget_start(uint8_t ch)
{
    struct stepq *q = &stepq[ch];
    if (q->started && (int32_t)(ticks_now() - q->start_tick) < 0)
        q->started = 0;
}

void stepgen_set_detached(uint8_t ch, uint8_t detached)
{
    struct stepq *q = &stepq[ch];
    uint8_t sreg = irq_save();
    q->detached = detached ? 1 : 0;
    update_slow(q);
    irq_restore(sreg);
}

void stepgen_set_pcnt(uint8_t ch, uint8_t flags, int16_t low, int16_t high, int16_t value)
{
    struct stepq *q = &stepq[ch];
    uint8_t sreg = irq_save();
    q->pcnt_low = low;
    q->pcnt_high = high;
    q->pcnt = value;
    q->pcnt_flags = flags;
    update_slow(q);
    irq_restore(sreg);
}

void stepgen_pcnt_clear(uint8_t ch)
{
    uint8_t sreg = irq_save();
    stepq[ch].pcnt = 0;
    irq_restore(sreg);
}

void stepgen_commit_entry(uint8_t ch)
{
    struct stepq *q = &stepq[ch];
    __asm__ __volatile__("" ::: "memory");  /* the entry is written before it is seen */
    q->wp = q->wp + 1;
}
