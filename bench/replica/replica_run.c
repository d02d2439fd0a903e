/* The firmware replica's runner (bench/replica/replica.py): runs an AVR ELF in simavr
 * and records, by CPU cycle,
 *   PREFIX.pins  "cycle PORTBIT level" for every change of the named port pins,
 *   PREFIX.ev    "cycle V n [| steps of each queue ...]"  an interrupt vector entered
 *                (for vector TASK_VECTOR the queued entries' step counts follow),
 *                "cycle R"                                   a reti executed,
 *                "cycle M k this ticks steps a32 a16"       function k of MARKS entered
 *                (this = r25:r24; ticks/steps read from the struct r23:r22 points to;
 *                a32 = r23..r20, a16 = r25:r24: a function's arguments as numbers),
 *                "cycle C pc" / "cycle S pc"    the main program (no interrupt running)
 *                turned interrupts off / on again at byte address pc (its critical
 *                sections: cli ... sei, or SREG saved and restored),
 *                "cycle c pc" / "cycle s pc"  (only with TASK_SECTIONS) the same for the
 *                ramp task's own code (TASK_VECTOR at depth 1; its entry is with them off),
 *                "cycle Q q rp wp t:s ..."   (only with READ_PC) the ramp task's fill read
 *                queue q's indices (ticksInQueue(), inlined: the instruction after its
 *                critical section, Z = the queue's next_write_idx): the indices and every
 *                entry from the read index on, ticks:steps (the running entry first),
 *                "cycle P f:n ..."   (only with PROFILE) before each M line and at the
 *                ramp task's reti: the cycles the task's own code spent in function f
 *                (the f-th range of PROFILE) since the last P line, n > 0 only.
 *
 *   replica_run ELF MCU MILLISECONDS PREFIX PIN...      (PIN: port letter + bit, "B1")
 *
 * Environment: MARKS (comma-separated hex byte addresses), TASK_VECTOR, QUEUES and
 * QUEUE_BASE (hex data address of the queue array; 119-byte queues of 16 entries of
 * 6 bytes, read_idx/next_write_idx after the entries: FastAccelStepper 1.2.6 on AVR);
 * READ_PC (optional): hex byte address of the fill's queue read (replica.py finds it);
 * PROFILE (optional): a file of "start end [name]" byte-address ranges (hex), one
 * function a line.
 * TIMER_CHECK (optional): a file that receives timer 1's events, for
 * bench/replica/timer_check.py (needs TASK_VECTOR = timer 1's overflow vector and QUEUES
 * = its compare channels, whose vectors precede it):
 *   "T cycle"          the overflow's interrupt flag raised,
 *   "C cycle ch"       compare channel ch's interrupt flag raised (while not pending),
 *   "W cycle ch value" OCR1x (data 0x88 + 2 ch) holds a new value after an instruction.
 * Build against an upstream simavr tree (replica.py does it).
 */
#include <inttypes.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>

#include "avr_ioport.h"
#include "avr_uart.h"
#include "sim_interrupts.h"
#include "sim_avr.h"
#include "sim_elf.h"

static avr_t *avr;
static FILE *pins, *ev;
static unsigned marks[16];
static int n_marks, task_vector, n_queues, queue_base;
static unsigned read_pc; /* READ_PC: the fill's ticksInQueue() read (0: none) */

enum { QUEUE_SIZE = 119, ENTRY_SIZE = 6, ENTRIES = 16 };

static FILE *tcheck; /* TIMER_CHECK */
static uint16_t ocr_seen[3];

static void timer_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    int ch = (int)(intptr_t)param;
    if (!value)
        return;
    if (ch < 0)
        fprintf(tcheck, "T %" PRIu64 "\n", avr->cycle);
    else
        fprintf(tcheck, "C %" PRIu64 " %d\n", avr->cycle, ch);
}

static void timer_ocr_step(void)
{
    for (int ch = 0; ch < n_queues && ch < 3; ch++) {
        uint16_t v = avr->data[0x88 + 2 * ch] | (avr->data[0x89 + 2 * ch] << 8);
        if (v != ocr_seen[ch]) {
            ocr_seen[ch] = v;
            fprintf(tcheck, "W %" PRIu64 " %d %u\n", avr->cycle, ch, v);
        }
    }
}

static void pin_hook(struct avr_irq_t *irq, uint32_t value, void *param)
{
    (void)irq;
    fprintf(pins, "%" PRIu64 " %s %u\n", avr->cycle, (const char *)param, value & 1);
}

static int depth, loop_i = 1; /* interrupts running; the main program's I flag */
static int task_sections, task_i; /* TASK_SECTIONS: the ramp task's own I flag too */
static uint32_t last_pc;

/* PROFILE: the ramp task's own cycles by function (the vectors entered, innermost last) */
enum { MAX_FUNCS = 1024, MAX_DEPTH = 16 };
static uint16_t *func_of; /* flash byte address -> range index + 1 (0: none) */
static uint64_t spent[MAX_FUNCS + 1], prof_cycle;
static uint32_t prof_pc;
static int n_funcs, vectors[MAX_DEPTH];

static void load_profile(const char *path)
{
    FILE *f = fopen(path, "r");
    if (!f) {
        perror(path);
        exit(1);
    }
    func_of = calloc(avr->flashend + 2, sizeof *func_of);
    unsigned a, b;
    char line[1024];
    while (n_funcs < MAX_FUNCS && fgets(line, sizeof line, f) && sscanf(line, "%x %x", &a, &b) == 2) {
        n_funcs++;
        for (unsigned x = a; x < b && x <= avr->flashend; x++)
            func_of[x] = (uint16_t)n_funcs;
    }
    fclose(f);
}

static void profile_step(void) /* the cycles since the last call, to its instruction */
{
    if (depth > 0 && depth <= MAX_DEPTH && vectors[depth - 1] == task_vector)
        spent[func_of[prof_pc]] += avr->cycle - prof_cycle;
    prof_cycle = avr->cycle;
    prof_pc = avr->pc;
}

static void profile_flush(void)
{
    fprintf(ev, "%" PRIu64 " P", avr->cycle);
    for (int i = 0; i <= n_funcs; i++)
        if (spent[i]) {
            fprintf(ev, " %d:%" PRIu64, i - 1, spent[i]);
            spent[i] = 0;
        }
    fputc('\n', ev);
}

static void record(void)
{
    uint32_t pc = avr->pc;
    uint16_t op = avr->flash[pc] | (avr->flash[pc + 1] << 8);
    if (func_of)
        profile_step();
    if (op == 0x9518) { /* reti */
        if (func_of && depth > 0 && depth <= MAX_DEPTH && vectors[depth - 1] == task_vector)
            profile_flush();
        fprintf(ev, "%" PRIu64 " R\n", avr->cycle);
        if (depth > 0)
            depth--;
        return;
    }
    if (pc && pc < 0x100 && !(pc & 3)) { /* a jmp of the vector table: entered */
        int vector = (int)(pc >> 2);
        if (depth < MAX_DEPTH)
            vectors[depth] = vector;
        depth++;
        fprintf(ev, "%" PRIu64 " V %d", avr->cycle, vector);
        if (depth == 1 && vector == task_vector)
            task_i = 0; /* entered with interrupts off */
        if (vector == task_vector) {
            for (int q = 0; q < n_queues; q++) {
                const uint8_t *b = avr->data + queue_base + QUEUE_SIZE * q;
                uint8_t rp = b[ENTRY_SIZE * ENTRIES], wp = b[ENTRY_SIZE * ENTRIES + 1];
                fputs(" |", ev);
                for (uint8_t i = rp; i != wp; i++)
                    fprintf(ev, " %u", b[ENTRY_SIZE * (i & (ENTRIES - 1))]);
            }
        }
        fputc('\n', ev);
        return;
    }
    if (task_sections && depth == 1 && vectors[0] == task_vector && avr->sreg[S_I] != task_i) {
        task_i = avr->sreg[S_I]; /* the task's own sei / cli, by the instruction before */
        fprintf(ev, "%" PRIu64 " %c %x\n", avr->cycle, task_i ? 's' : 'c', last_pc);
    }
    if (depth == 0 && avr->sreg[S_I] != loop_i) { /* by the instruction before this one */
        loop_i = avr->sreg[S_I];
        fprintf(ev, "%" PRIu64 " %c %x\n", avr->cycle, loop_i ? 'S' : 'C', last_pc);
    }
    last_pc = pc;
    if (read_pc && pc == read_pc) {
        int z = avr->data[30] | (avr->data[31] << 8);
        int q = (z - queue_base) / QUEUE_SIZE;
        const uint8_t *b = avr->data + queue_base + QUEUE_SIZE * q;
        uint8_t rp = b[ENTRY_SIZE * ENTRIES], wp = b[ENTRY_SIZE * ENTRIES + 1];
        fprintf(ev, "%" PRIu64 " Q %d %u %u", avr->cycle, q, rp, wp);
        for (uint8_t i = rp; i != wp; i++) {
            const uint8_t *e = b + ENTRY_SIZE * (i & (ENTRIES - 1));
            fprintf(ev, " %u:%u", e[2] | (e[3] << 8), e[0]);
        }
        fputc('\n', ev);
    }
    for (int k = 0; k < n_marks; k++) {
        if (pc != marks[k])
            continue;
        unsigned p = avr->data[22] | (avr->data[23] << 8);
        unsigned ticks = 0, steps = 0;
        if (p + 2 <= avr->ramend) {
            ticks = avr->data[p] | (avr->data[p + 1] << 8);
            steps = avr->data[p + 2];
        }
        if (func_of)
            profile_flush();
        const uint8_t *r = avr->data; /* r20..r25: the arguments after `this` */
        fprintf(ev, "%" PRIu64 " M %d %u %u %u %" PRIu32 " %u\n", avr->cycle, k,
                r[24] | (r[25] << 8), ticks, steps,
                (uint32_t)r[20] | ((uint32_t)r[21] << 8) | ((uint32_t)r[22] << 16)
                | ((uint32_t)r[23] << 24), r[24] | (r[25] << 8));
        return;
    }
}

int main(int argc, char **argv)
{
    if (argc < 5) {
        fprintf(stderr, "usage: %s ELF MCU MILLISECONDS PREFIX PIN...\n", argv[0]);
        return 2;
    }
    elf_firmware_t fw;
    memset(&fw, 0, sizeof fw);
    if (elf_read_firmware(argv[1], &fw)) {
        fprintf(stderr, "cannot read %s\n", argv[1]);
        return 1;
    }
    avr = avr_make_mcu_by_name(argv[2]);
    if (!avr) {
        fprintf(stderr, "unknown MCU %s\n", argv[2]);
        return 1;
    }
    avr_init(avr);
    avr->log = LOG_ERROR;
    fw.frequency = 16000000;
    strncpy(fw.mmcu, argv[2], sizeof fw.mmcu - 1);
    avr_load_firmware(avr, &fw);
    avr->frequency = 16000000;
    char name[1024];
    snprintf(name, sizeof name, "%s.pins", argv[4]);
    pins = fopen(name, "w");
    snprintf(name, sizeof name, "%s.ev", argv[4]);
    ev = fopen(name, "w");
    if (!pins || !ev) {
        perror(argv[4]);
        return 1;
    }
    for (int i = 5; i < argc; i++) {
        avr_irq_t *irq = avr_io_getirq(avr, AVR_IOCTL_IOPORT_GETIRQ(argv[i][0]), atoi(argv[i] + 1));
        if (!irq) {
            fprintf(stderr, "no pin %s\n", argv[i]);
            return 1;
        }
        avr_irq_register_notify(irq, pin_hook, argv[i]);
    }
    const char *env = getenv("MARKS");
    if (env) {
        char *list = strdup(env);
        for (char *t = strtok(list, ","); t && n_marks < 16; t = strtok(NULL, ","))
            marks[n_marks++] = (unsigned)strtoul(t, NULL, 16);
    }
    if (getenv("TASK_VECTOR")) {
        task_vector = atoi(getenv("TASK_VECTOR"));
        n_queues = getenv("QUEUES") ? atoi(getenv("QUEUES")) : 0;
        queue_base = getenv("QUEUE_BASE") ? (int)strtoul(getenv("QUEUE_BASE"), NULL, 16) : 0;
    }
    task_sections = getenv("TASK_SECTIONS") != NULL;
    if (getenv("READ_PC"))
        read_pc = (unsigned)strtoul(getenv("READ_PC"), NULL, 16);
    if (getenv("PROFILE"))
        load_profile(getenv("PROFILE"));
    if (getenv("TIMER_CHECK") && task_vector) {
        tcheck = fopen(getenv("TIMER_CHECK"), "w");
        if (!tcheck) {
            perror(getenv("TIMER_CHECK"));
            return 1;
        }
        avr_irq_t *v = avr_get_interrupt_irq(avr, (uint8_t)task_vector);
        if (v)
            avr_irq_register_notify(v + AVR_INT_IRQ_PENDING, timer_hook, (void *)(intptr_t)-1);
        for (int ch = 0; ch < n_queues && ch < 3; ch++) {
            v = avr_get_interrupt_irq(avr, (uint8_t)(task_vector - n_queues + ch));
            if (v)
                avr_irq_register_notify(v + AVR_INT_IRQ_PENDING, timer_hook, (void *)(intptr_t)ch);
        }
    }
    uint32_t flags = 0; /* the console's characters are not wanted on stdout */
    avr_ioctl(avr, AVR_IOCTL_UART_GET_FLAGS('0'), &flags);
    flags &= ~AVR_UART_FLAG_STDIO;
    avr_ioctl(avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
    uint64_t end = (uint64_t)(atof(argv[3]) * 16000);
    while (avr->cycle < end) {
        record();
        int state = avr_run(avr);
        if (tcheck)
            timer_ocr_step();
        if (state == cpu_Done || state == cpu_Crashed)
            break;
    }
    fclose(pins);
    fclose(ev);
    if (tcheck)
        fclose(tcheck);
    return 0;
}
