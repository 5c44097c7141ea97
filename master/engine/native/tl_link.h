/* The shared-memory link between the tick loop and an isolated FMU's host (docs/master.md, "FMUs that are not ours run in their own process"): one
   round trip a step through a sealed memfd segment both processes map, a sequence number each way and a futex to wait
   on it (after a short spin). The master's side is tl_loop.c's step_linked, the host's tl_host.c.

   The segment, at offsets the master chooses and tells the host (no pointer in it):
     TL_LINK_REQUEST     uint32 request: the sequence number of the last request (the host waits on it)
     +4                  uint32 the host is asleep on request (then the master wakes it)
     TL_LINK_REPLY       uint32 reply: the sequence number of the request answered last (the master waits on it)
     +4                  uint32 the master is asleep on reply
     TL_LINK_CALL        double t, double h, uint32 op (tl_link_op), uint32 spare, int64 k (the tick: a clocked FMU's
                         clocks are due by it), int64 sent_ns (when the master published it: tl_link_waited)
     in_offset[g]        group g's input values, as the plan's arrays hold them (double, int)
     out_offset          the reply's header (TL_LINK_HEADER bytes: tl_link_reply below), then the outputs: Real, Integer,
                         Boolean, as the plan's arrays hold them
   The host can write anything anywhere in the segment: the master reads only its own offsets, copies what it reads
   and checks every field before use (step_linked). The segment is sealed against shrinking, so no read faults. */
#ifndef TL_LINK_H
#define TL_LINK_H

#include <stdint.h>
#include <string.h>

#define TL_LINK_REQUEST 0
#define TL_LINK_REPLY 64 /* another cache line than the request's */
#define TL_LINK_CALL 128
#define TL_LINK_INPUTS 192
#define TL_LINK_HEADER 64

enum tl_link_op { TL_LINK_STEP = 1, TL_LINK_YIELD = 2 }; /* yield: the host goes back to its pipe (a rare request) */
/* which call failed in the host (tl_link_reply.call); TL_LINK_KERNEL: a step of a clocked or Scheduled Execution FMU,
   which the host makes with the kernel's own sequence (tl_step_alone), failed as its error record says (kind, status,
   where: the group or the clock, type) */
enum tl_link_call { TL_LINK_OK = 0, TL_LINK_SET = 1, TL_LINK_DO_STEP = 2, TL_LINK_GET = 3, TL_LINK_KERNEL = 4 };

/* The reply's header at out_offset. */
typedef struct {
    int32_t status;    /* the failed call's fmi2Status (fmi2Discard with ended: the FMU asked to end the run) */
    int32_t call;      /* tl_link_call */
    int32_t where;     /* set: the group; get: the type */
    int32_t ended;     /* 1: fmi2Discard with fmi2Terminated true; last_time is its last successful time */
    double last_time;
    int64_t host_ns;   /* the host's time in the FMU's calls of this step (CLOCK_MONOTONIC) */
    uint32_t out_bytes; /* the outputs' bytes that follow: the master checks them against its own count */
    uint32_t spare;
    int32_t kind;      /* TL_LINK_KERNEL: the tl_error_kind */
    int32_t type;      /* TL_LINK_KERNEL: the value type of a failed get */
    int64_t sent_ns;   /* when the host published the reply (CLOCK_MONOTONIC): tl_link_waited */
} tl_link_reply;

#define TL_LINK_SENT (TL_LINK_CALL + 32) /* the request's sent_ns */
typedef char tl_link_reply_fits[sizeof(tl_link_reply) <= TL_LINK_HEADER ? 1 : -1];

/* The kernel's step of one instance of a plan whose inputs are in place (tl_loop.c's tl_step_alone), for a host: a
   failure or an end asked for goes into the reply, as a linked step's would. */
typedef int (*tl_step_alone_fn)(void *plan, int64_t k, double t, double h, tl_link_reply *reply);
int tl_step_alone(void *plan, int64_t k, double t, double h, tl_link_reply *reply);

static inline uint32_t *tl_link_word(unsigned char *base, int64_t offset) { return (uint32_t *)(void *)(base + offset); }

#if defined(__linux__)
#include <linux/futex.h>
#include <sys/syscall.h>
#include <time.h>
#include <unistd.h>

/* Wait while *word == value, at most ns (a shared futex: the other process's wake reaches it). */
static inline void tl_futex_wait(uint32_t *word, uint32_t value, int64_t ns) {
    struct timespec ts;
    ts.tv_sec = (time_t)(ns / 1000000000);
    ts.tv_nsec = (long)(ns % 1000000000);
    syscall(SYS_futex, word, FUTEX_WAIT, value, &ts, NULL, 0);
}

static inline void tl_futex_wake(uint32_t *word) { syscall(SYS_futex, word, FUTEX_WAKE, 1, NULL, NULL, 0); }
#define TL_LINK_AVAILABLE 1
#else
static inline void tl_futex_wait(uint32_t *word, uint32_t value, int64_t ns) { (void)word, (void)value, (void)ns; }
static inline void tl_futex_wake(uint32_t *word) { (void)word; }
#define TL_LINK_AVAILABLE 0
#endif

/* Publish sequence number seq in word (after everything written before it) and wake the other side if it sleeps on it
   (it says so in the word after; seq_cst on both sides: a sleeper either sees the new value or is woken). */
static inline void tl_link_publish(uint32_t *word, uint32_t seq) {
    __atomic_store_n(word, seq, __ATOMIC_SEQ_CST);
    if (__atomic_load_n(word + 1, __ATOMIC_SEQ_CST)) tl_futex_wake(word);
}

/* Sleep on word while it holds value, at most ns, saying so in the word after. */
static inline void tl_link_sleep(uint32_t *word, uint32_t value, int64_t ns) {
    __atomic_store_n(word + 1, 1u, __ATOMIC_SEQ_CST);
    if (__atomic_load_n(word, __ATOMIC_SEQ_CST) == value) tl_futex_wait(word, value, ns);
    __atomic_store_n(word + 1, 0u, __ATOMIC_SEQ_CST);
}

/* While spinning: first the processor's spin-wait hint, which sees the other side's answer within a fraction of a
   µs, for pause_ns (tl_pause_budget); then sched_yield (a system call, about 1.3 µs here, that lends the core to any
   other runnable process: on a busy machine the other side may be the one waiting for it). */
#include <sched.h>
static inline void tl_spin_wait(int64_t start, int64_t now, int64_t pause_ns) {
    if (now - start >= pause_ns) {
        sched_yield();
        return;
    }
#if defined(__x86_64__) || defined(__i386__)
    __builtin_ia32_pause();
#elif defined(__aarch64__) || defined(__arm__)
    __asm__ __volatile__("yield");
#endif
}

#define TL_LINK_PAUSE_NS 10000     /* the least time on the hint */
#define TL_LINK_PAUSE_MAX_NS 50000 /* the most */

/* How long a wait stays on the hint: one and a half times the usual wait (tl_spin_learn), within the two bounds above.
   An answer that comes when it usually does is then seen within a fraction of a µs, not after a sched_yield's system
   call (measured: a host whose next request usually comes 10 to 12 µs after its reply saw it 0.65 µs later on average
   in sched_yield); one that is late (the other side descheduled) finds the core lent soon. */
static inline int64_t tl_pause_budget(int64_t usual) {
    int64_t want = usual + usual / 2;
    return want < TL_LINK_PAUSE_NS ? TL_LINK_PAUSE_NS : want > TL_LINK_PAUSE_MAX_NS ? TL_LINK_PAUSE_MAX_NS : want;
}

#define TL_LINK_SPIN_MAX_NS 500000 /* the longest spin before sleeping on the futex */

/* How long the next wait spins before it sleeps, from the usual wait (tl_spin_learn's average): TL_LINK_SPIN_MAX_NS
   where the usual wait is within half of it, else base (the answer usually takes long: sleep soon, waking costs less
   than spinning then). A futex wake-up costs 100 µs and more on this VM, in both processes' time: a wait that sleeps
   when the usual one would not costs more than the step, and the usual wait is only an average (a pythonfmu
   controller's step: median 27 µs, p99 160 µs). Past its first tl_pause_budget the spin lends the core (sched_yield),
   so spinning long costs other processes little. */
static inline int64_t tl_spin_budget(int64_t base, int64_t usual) {
    return 2 * usual <= TL_LINK_SPIN_MAX_NS && base < TL_LINK_SPIN_MAX_NS ? TL_LINK_SPIN_MAX_NS : base;
}

/* How long a wait that began at start and saw the answer at now waited for it: until the other side sent it (sent,
   its clock reading as it published; CLOCK_MONOTONIC is one clock for every process on the machine), not until this
   side woke. So a wait that slept on the futex teaches tl_spin_learn the other side's time, not the wake-up's (tens to
   hundreds of µs on a VM): counting that made a wait that slept once usually long, then spin for less and sleep again,
   every step (measured: a pythonfmu controller's steps at 140 to 400 µs a tick instead of 45 to 55 for seconds at a
   time; tl_spin_budget's longer spin was needed too). sent comes from the other process: any value is kept within [start, now]. */
static inline int64_t tl_link_waited(int64_t start, int64_t sent, int64_t now) {
    return sent < start ? 0 : sent > now ? now - start : sent - start;
}

/* The usual wait after one more (an average over the last eight or so; a wait beyond TL_LINK_SPIN_MAX_NS counts as
   that, so that one preempted step does not turn spinning off for long). */
static inline int64_t tl_spin_learn(int64_t usual, int64_t waited) {
    if (waited > TL_LINK_SPIN_MAX_NS) waited = TL_LINK_SPIN_MAX_NS;
    if (waited < 0) waited = 0;
    return usual + (waited - usual) / 8;
}

#endif
