/* An FMI 3.0 Scheduled Execution importer in C, written from the standard (FMI 3.0, chapter 5 "FMI for Scheduled
   Execution", and the co-simulation call sequences for the other FMUs of the loop), with no Python in the process:
   the scheduler of a Scheduled Execution FMU, a second importer beside tiltload's own.

   Every FMU named in the plan is loaded; co-simulation ones (F) are stepped as in fmi3_loop_host.c (Event Mode at
   their clocks' ticks, fmi3DoStep); a Scheduled Execution one (S) is instantiated with fmi3InstantiateScheduledExecution
   and the host's preemption lock callbacks, and at every tick where some of its clocks are due the host's scheduler
   activates their model partitions (fmi3ActivateModelPartition) one after the other in priority order: for each,
   the inputs it clocks are set, the partition activated at the tick's time, the outputs it clocks read.

   Priorities are the host's own: rate-monotonic from the clocks' periods (the shorter period first, the standard's
   recommendation for periodic clocks), then each partition placed below every partition it reads at the same instant
   (the D lines, from the model description's output dependencies; FMI 3.0 5.1.1: the importer derives the order
   from priorities and input-output relations). The order found must be the one the FMU's declared `priority`
   attributes give, or the run stops; --rate-monotonic-only skips the second rule (and the check), to show what the
   FMU says when its partitions run in the plain rate-monotonic order.

   Preemption: a partition may be preempted where the FMU allows it, at its fmi3UnlockPreemptionCallback with no lock
   held. With --replay FILE --preempt the host runs the Scheduled Execution FMU alone on recorded inputs (the lines
   --record FILE wrote in a loop run) and, at every such point in a partition, first runs every partition of the
   next instant that has a higher priority (as a real-time scheduler would when a partition overruns into the next
   period); without --preempt it runs them in order. Lock callbacks are counted and must balance.

   usage: fmi3_se_host PLAN [--rate-monotonic-only] [--record FILE] [--replay FILE [--preempt]] [--reactivate]
   --reactivate: at the first preemption point, the running partition is activated again at its own instant (the FMU
   must refuse it with fmi3Error); the host reports which, and exits 1 (the instance is Terminated).
   PLAN is text, one item a line:
     F name binary token           a co-simulation FMU instance (stepping order = file order)
     S name binary token           a Scheduled Execution FMU instance (its partitions run at its place in that order)
     K name vr interval shift prio one of its periodic input clocks (interval and shift in ticks; prio: declared)
     V name vr clockvr             one of its variables (input or output) clocked by that clock
     D name consumer producer      Scheduled Execution: partition consumer's outputs depend on producer's inputs
     P name R|I|B|S vr value       a parameter or start value (S: the rest of the line)
     C src R|I|B vr dst vr         a connection from src's output to dst's input
     T tick ticks                  the tick (s) and how many to run
     O name vr                     a Float64 output printed after every tick ("k name vr value", C99 hex float)
   Exit 0 when every call succeeded. */
#include "fmi3_host_common.h"

#define MAX_NEST 16

/* A recorded input of the Scheduled Execution FMU: set at tick k before the partition that clocks it. */
typedef struct {
  long k;
  fmi3ValueReference vr;
  char type;
  double value;
} Recorded;

/* The host's one run. The preemption callbacks of FMI 3.0 take no argument, so what they need is reached from here. */
typedef struct {
  Fmu fmus[MAX_FMUS];
  Link links[MAX_LINKS];
  int n_fmus, n_links, failed;
  double tick;
  Outputs out;
  FILE* record;
  Recorded* replay;
  long n_replay;
  int preempt;
  int reactivate; /* --reactivate: at the first preemption point, the running partition activated again (must be refused) */
  int reactivated; /* 1 refused with fmi3Error, 2 accepted, 3 being tried */
  /* scheduling: the partitions running (innermost last), the lock depth, the counts */
  int running_fmu[MAX_NEST], running_clock[MAX_NEST], n_running;
  long running_tick[MAX_NEST];
  int lock_depth;
  long locks, preemptions;
} Host;

/* The one file-scope mutable state: fmi3LockPreemptionCallback and fmi3UnlockPreemptionCallback take no argument,
   so they reach the run here. */
static Host host_run;

/* ---- data exchange ---------------------------------------------------------------------------------------------- */
/* Read fi's outputs into its links: which = 0 the non-clocked, 1 the clocked ones of due clocks, 2 all; or, with
   clock != 0, those clocked by that clock. */
static int read_outputs(Host* h, int fi, int which, const int* due, fmi3ValueReference only) {
  int j, failed = 0;
  Fmu* f = &h->fmus[fi];
  for (j = 0; j < h->n_links; ++j) {
    Link* l = &h->links[j];
    fmi3ValueReference clock;
    if (l->src != fi) continue;
    clock = clock_of(f, l->src_vr);
    if (only ? clock != only : (which == 0 && clock) || (which == 1 && (!clock || !is_due(f, clock, due)))) continue;
    if (l->type == 'R') failed |= f->get_float64(f->c, &l->src_vr, 1, &l->real, 1) != fmi3OK;
    else if (l->type == 'I') failed |= f->get_int32(f->c, &l->src_vr, 1, &l->integer, 1) != fmi3OK;
    else failed |= f->get_boolean(f->c, &l->src_vr, 1, &l->boolean, 1) != fmi3OK;
  }
  for (j = 0; j < h->out.n; ++j) { /* the printed outputs a partition or an Event Mode computed */
    fmi3ValueReference clock = clock_of(f, h->out.vr[j]);
    if (h->out.fmu[j] == fi && clock && (only ? clock == only : which == 1 && is_due(f, clock, due)))
      failed |= f->get_float64(f->c, &h->out.vr[j], 1, &h->out.held[j], 1) != fmi3OK;
  }
  return failed;
}

/* Set fi's connected inputs (which and only as for read_outputs); tick: written with them to the record file. */
static int set_inputs(Host* h, int fi, int which, const int* due, fmi3ValueReference only, long tick) {
  int j, failed = 0;
  Fmu* f = &h->fmus[fi];
  for (j = 0; j < h->n_links; ++j) {
    Link* l = &h->links[j];
    fmi3ValueReference clock;
    if (l->dst != fi) continue;
    clock = clock_of(f, l->dst_vr);
    if (only ? clock != only : (which == 0 && clock) || (which == 1 && (!clock || !is_due(f, clock, due)))) continue;
    if (l->type == 'R') failed |= f->set_float64(f->c, &l->dst_vr, 1, &l->real, 1) != fmi3OK;
    else if (l->type == 'I') failed |= f->set_int32(f->c, &l->dst_vr, 1, &l->integer, 1) != fmi3OK;
    else failed |= f->set_boolean(f->c, &l->dst_vr, 1, &l->boolean, 1) != fmi3OK;
    if (h->record != NULL && f->scheduled)
      fprintf(h->record, "%ld %u %c %a\n", tick, l->dst_vr, l->type,
              l->type == 'R' ? l->real : l->type == 'I' ? (double)l->integer : (double)l->boolean);
  }
  return failed;
}

/* Replay: the recorded inputs of tick clocked by clock, set (the file is in tick order). */
static int set_recorded(Host* h, Fmu* f, fmi3ValueReference clock, long tick) {
  long lo = 0, hi = h->n_replay, i;
  int failed = 0;
  while (lo < hi) { /* the first entry of tick */
    const long mid = (lo + hi) / 2;
    if (h->replay[mid].k < tick) lo = mid + 1;
    else hi = mid;
  }
  for (i = lo; i < h->n_replay && h->replay[i].k == tick; ++i) {
    const Recorded* r = &h->replay[i];
    if (clock_of(f, r->vr) != clock) continue;
    if (r->type == 'R') failed |= f->set_float64(f->c, &r->vr, 1, &r->value, 1) != fmi3OK;
    else if (r->type == 'I') {
      const fmi3Int32 v = (fmi3Int32)r->value;
      failed |= f->set_int32(f->c, &r->vr, 1, &v, 1) != fmi3OK;
    } else {
      const fmi3Boolean v = r->value != 0.0;
      failed |= f->set_boolean(f->c, &r->vr, 1, &v, 1) != fmi3OK;
    }
  }
  return failed;
}

/* ---- the scheduler ------------------------------------------------------------------------------------------------ */
/* Levels: the rate-monotonic rank of each clock's period, then (unless rm_only) each partition below those it reads.
   Returns 1 when the order differs from the declared priorities' (pairwise), unless rm_only. */
static int derive_levels(Fmu* f, int rm_only) {
  int a, b, d, round, mismatch = 0;
  for (a = 0; a < f->n_clocks; ++a) {
    int rank = 0;
    for (b = 0; b < f->n_clocks; ++b) { /* distinct shorter periods */
      int seen = 0, e;
      for (e = 0; e < b; ++e) seen |= f->clocks[e].interval == f->clocks[b].interval;
      rank += !seen && f->clocks[b].interval < f->clocks[a].interval;
    }
    f->clocks[a].level = rank;
  }
  for (round = 0; !rm_only && round < f->n_clocks; ++round)
    for (d = 0; d < f->n_deps; ++d) {
      Clock *consumer = NULL, *producer = NULL;
      for (a = 0; a < f->n_clocks; ++a) {
        if (f->clocks[a].vr == f->dep_consumer[d]) consumer = &f->clocks[a];
        if (f->clocks[a].vr == f->dep_producer[d]) producer = &f->clocks[a];
      }
      if (consumer && producer && consumer->level <= producer->level) consumer->level = producer->level + 1;
    }
  for (a = 0; a < f->n_clocks; ++a)
    for (b = 0; b < f->n_clocks; ++b) {
      const int ours = (f->clocks[a].level > f->clocks[b].level) - (f->clocks[a].level < f->clocks[b].level);
      const int theirs = (f->clocks[a].declared > f->clocks[b].declared) - (f->clocks[a].declared < f->clocks[b].declared);
      mismatch |= ours != theirs;
    }
  fprintf(stderr, "%s partitions (clock vr: host level / declared priority):", f->name);
  for (a = 0; a < f->n_clocks; ++a) fprintf(stderr, " %u:%d/%u", f->clocks[a].vr, f->clocks[a].level, f->clocks[a].declared);
  fprintf(stderr, "%s\n", mismatch ? (rm_only ? " (rate-monotonic only: not the declared order)" : " MISMATCH") : "");
  return mismatch && !rm_only;
}

static int activate(Host* h, int fi, int j, long tick);

/* At a preemption point: the partitions of the instant after the outermost running one's (the period it overran
   into: the latest instant released) that outrank the innermost running one run first. */
static void preempt_now(Host* h) {
  for (;;) {
    const int fi = h->running_fmu[h->n_running - 1], j = h->running_clock[h->n_running - 1];
    const long next = h->running_tick[0] + 1;
    Fmu* f = &h->fmus[fi];
    int best = -1, a;
    for (a = 0; a < f->n_clocks; ++a) {
      const Clock* k = &f->clocks[a];
      if (due_at(k, next) && k->ran_at < next && k->level < f->clocks[j].level && (best < 0 || k->level < f->clocks[best].level))
        best = a;
    }
    if (best < 0 || h->n_running >= MAX_NEST) return;
    h->preemptions += 1;
    h->failed |= activate(h, fi, best, next);
  }
}

static void lock_preemption(void) {
  host_run.lock_depth += 1;
  host_run.locks += 1;
}

static void unlock_preemption(void) {
  Host* h = &host_run;
  h->lock_depth -= 1;
  if (h->lock_depth < 0) {
    fprintf(stderr, "fmi3UnlockPreemptionCallback without a lock\n");
    h->failed = 1;
    h->lock_depth = 0;
  }
  if (h->lock_depth == 0 && h->reactivate && !h->reactivated && h->n_running > 0) { /* the running one, again, at its instant */
    const int fi = h->running_fmu[h->n_running - 1], j = h->running_clock[h->n_running - 1];
    Fmu* f = &h->fmus[fi];
    fmi3Status status;
    h->reactivated = 3; /* in progress: the refusal's own unlock comes back here, and must not reactivate again */
    status = f->activate(f->c, f->clocks[j].vr, (double)h->running_tick[h->n_running - 1] * h->tick);
    h->reactivated = status == fmi3Error ? 1 : 2;
    fprintf(stderr, "reactivation of partition %u from its unlock callback: %s\n", f->clocks[j].vr,
            status == fmi3Error ? "refused with fmi3Error" : "ACCEPTED");
  }
  if (h->lock_depth == 0 && h->preempt && h->n_running > 0) preempt_now(h); /* a preemption point */
}

/* One model partition: its inputs, fmi3ActivateModelPartition at the tick's time, its outputs. */
static int activate(Host* h, int fi, int j, long tick) {
  Fmu* f = &h->fmus[fi];
  Clock* k = &f->clocks[j];
  int failed = 0;
  if (h->replay != NULL) failed |= set_recorded(h, f, k->vr, tick);
  else failed |= set_inputs(h, fi, 1, NULL, k->vr, tick);
  h->running_fmu[h->n_running] = fi;
  h->running_clock[h->n_running] = j;
  h->running_tick[h->n_running++] = tick;
  k->ran_at = tick;
  if (f->activate(f->c, k->vr, (double)tick * h->tick) != fmi3OK) {
    fprintf(stderr, "%s: fmi3ActivateModelPartition(%u, t=%g) failed\n", f->name, k->vr, (double)tick * h->tick);
    failed = 1;
  }
  h->n_running -= 1;
  if (h->lock_depth != 0) {
    fprintf(stderr, "%s: partition %u returned with %d lock(s) held\n", f->name, k->vr, h->lock_depth);
    failed = 1;
  }
  return failed | read_outputs(h, fi, 0, NULL, k->vr);
}

/* The instant tick of a Scheduled Execution FMU: its due partitions in the host's order (level, then declaration). */
static int schedule(Host* h, int fi, long tick) {
  Fmu* f = &h->fmus[fi];
  int failed = 0, level, j, top = 0;
  if (h->replay == NULL) failed |= set_inputs(h, fi, 0, NULL, 0, tick); /* inputs no partition clocks */
  for (j = 0; j < f->n_clocks; ++j) top = f->clocks[j].level > top ? f->clocks[j].level : top;
  for (level = 0; level <= top && !failed; ++level)
    for (j = 0; j < f->n_clocks && !failed; ++j)
      if (f->clocks[j].level == level && due_at(&f->clocks[j], tick) && f->clocks[j].ran_at < tick)
        failed |= activate(h, fi, j, tick);
  return failed;
}

/* ---- co-simulation FMUs, as in fmi3_loop_host.c ------------------------------------------------------------------- */
static int event_mode(Host* h, int fi, const int* due) {
  Fmu* f = &h->fmus[fi];
  int failed = 0;
  if (!f->in_event) failed |= f->enter_event(f->c) != fmi3OK;
  failed |= set_inputs(h, fi, 0, due, 0, 0);
  failed |= set_due_clocks(f, due);
  failed |= set_inputs(h, fi, 1, due, 0, 0);
  failed |= read_outputs(h, fi, 1, due, 0); /* before the update: it deactivates the clocks */
  return leave_event_mode(f, failed);
}

static int step(Host* h, int fi, long tick) {
  Fmu* f = &h->fmus[fi];
  int due[MAX_CLOCKS], failed = 0;
  if (needs_event_mode(f, tick, due)) failed |= event_mode(h, fi, due);
  else failed |= set_inputs(h, fi, 0, due, 0, 0);
  failed |= step_fmu(f, (double)tick * h->tick, h->tick);
  return failed | read_outputs(h, fi, 0, due, 0);
}

/* ---- the replay file and the plan --------------------------------------------------------------------------------- */
static long read_replay(Host* h, const char* path) {
  FILE* in = fopen(path, "r");
  long cap = 1 << 16;
  char text[128];
  if (in == NULL) return -1;
  h->replay = (Recorded*)malloc(sizeof(Recorded) * (size_t)cap);
  while (h->replay != NULL && fgets(text, sizeof text, in)) {
    Recorded* r;
    unsigned vr;
    if (h->n_replay == cap) h->replay = (Recorded*)realloc(h->replay, sizeof(Recorded) * (size_t)(cap *= 2));
    if (h->replay == NULL) break;
    r = &h->replay[h->n_replay];
    if (sscanf(text, "%ld %u %c %la", &r->k, &vr, &r->type, &r->value) != 4) continue;
    r->vr = vr;
    h->n_replay += 1;
  }
  fclose(in);
  return h->replay == NULL ? -1 : h->n_replay;
}

int main(int argc, char** argv) {
  static char params[MAX_PARAMS][4096];
  Host* h = &host_run;
  char line[4096], name[64], other[64], binary[2048], type;
  int n_params = 0, i, rm_only = 0;
  long ticks = 0, k;
  FILE* plan;
  if (argc < 2 || (plan = fopen(argv[1], "r")) == NULL) {
    fprintf(stderr, "usage: %s PLAN [--rate-monotonic-only] [--record FILE] [--replay FILE [--preempt]] [--reactivate]\n",
            argv[0]);
    return 2;
  }
  for (i = 2; i < argc; ++i) {
    if (strcmp(argv[i], "--rate-monotonic-only") == 0) rm_only = 1;
    else if (strcmp(argv[i], "--preempt") == 0) h->preempt = 1;
    else if (strcmp(argv[i], "--reactivate") == 0) h->reactivate = 1;
    else if (strcmp(argv[i], "--record") == 0 && i + 1 < argc) h->record = fopen(argv[++i], "w");
    else if (strcmp(argv[i], "--replay") == 0 && i + 1 < argc) {
      if (read_replay(h, argv[++i]) < 0) return 2;
    } else {
      fprintf(stderr, "unknown argument %s\n", argv[i]);
      return 2;
    }
  }
  if (h->preempt && h->replay == NULL) {
    fprintf(stderr, "--preempt needs --replay: the next instant's inputs must be known\n");
    return 2;
  }
  while (fgets(line, sizeof line, plan)) {
    unsigned a, b, prio;
    long p, q;
    line[strcspn(line, "\n")] = '\0';
    if ((line[0] == 'F' || line[0] == 'S') && h->n_fmus < MAX_FMUS) {
      Fmu* f = &h->fmus[h->n_fmus];
      if (sscanf(line + 1, " %63s %2047s %127s", f->name, binary, f->token) != 3 || load(f, binary, true)) return 1;
      f->scheduled = line[0] == 'S';
      ++h->n_fmus;
    } else if (line[0] == 'K' && sscanf(line, "K %63s %u %ld %ld %u", name, &a, &p, &q, &prio) == 5) {
      Fmu* f = &h->fmus[find(h->fmus, h->n_fmus, name)];
      Clock* c = &f->clocks[f->n_clocks++];
      c->vr = a;
      c->interval = p;
      c->shift = q;
      c->declared = prio;
      c->ran_at = -1;
    } else if (line[0] == 'V' && sscanf(line, "V %63s %u %u", name, &a, &b) == 3) {
      Fmu* f = &h->fmus[find(h->fmus, h->n_fmus, name)];
      f->clocked_vr[f->n_clocked] = a;
      f->clocked_by[f->n_clocked++] = b;
    } else if (line[0] == 'D' && sscanf(line, "D %63s %u %u", name, &a, &b) == 3) {
      Fmu* f = &h->fmus[find(h->fmus, h->n_fmus, name)];
      f->dep_consumer[f->n_deps] = a;
      f->dep_producer[f->n_deps++] = b;
    } else if (line[0] == 'P' && n_params < MAX_PARAMS) {
      memcpy(params[n_params++], line, sizeof line); /* set in Initialization Mode, below */
    } else if (line[0] == 'C' && h->replay == NULL && sscanf(line, "C %63s %c %u %63s %u", name, &type, &a, other, &b) == 5) {
      Link* l = &h->links[h->n_links++];
      l->src = find(h->fmus, h->n_fmus, name);
      l->dst = find(h->fmus, h->n_fmus, other);
      l->type = type;
      l->src_vr = a;
      l->dst_vr = b;
    } else if (line[0] == 'T') {
      if (sscanf(line, "T %lf %ld", &h->tick, &ticks) != 2) return 2;
    } else if (line[0] == 'O' && sscanf(line, "O %63s %u", name, &a) == 2) {
      h->out.fmu[h->out.n] = find(h->fmus, h->n_fmus, name);
      h->out.held[h->out.n] = NAN;
      h->out.vr[h->out.n++] = a;
    }
  }
  fclose(plan);
  for (i = 0; i < h->n_fmus; ++i) {
    Fmu* f = &h->fmus[i];
    if (h->replay != NULL && !f->scheduled) continue; /* replay: the Scheduled Execution FMU alone */
    if (f->scheduled) {
      h->failed |= derive_levels(f, rm_only);
      f->c = f->instantiate_se(f->name, f->token, NULL, fmi3False, fmi3False, f->name, log_message, NULL, lock_preemption,
                               unlock_preemption);
    } else {
      f->c = f->instantiate(f->name, f->token, NULL, fmi3False, fmi3False, f->n_clocks > 0, fmi3False, NULL, 0, f->name,
                            log_message, NULL);
    }
    if (f->c == NULL) {
      fprintf(stderr, "%s: instantiation failed\n", f->name);
      return 1;
    }
    h->failed |= f->enter_init(f->c, fmi3False, 0.0, 0.0, fmi3False, 0.0) != fmi3OK;
  }
  for (i = 0; i < n_params; ++i) {
    sscanf(params[i], "P %63s", name);
    if (h->fmus[find(h->fmus, h->n_fmus, name)].c != NULL) h->failed |= set_parameter(h->fmus, h->n_fmus, params[i]);
  }
  for (i = 0; i < h->n_fmus; ++i) {
    Fmu* f = &h->fmus[i];
    int none[MAX_CLOCKS] = {0};
    if (f->c == NULL) continue;
    h->failed |= read_outputs(h, i, 2, none, 0); /* every output, clocked ones too: Initialization Mode */
    h->failed |= f->exit_init(f->c) != fmi3OK; /* Scheduled Execution: now in Clock Activation Mode */
    f->in_event = !f->scheduled && f->n_clocks > 0;
  }
  for (k = 0; k < ticks && !h->failed; ++k) {
    for (i = 0; i < h->n_fmus && !h->failed; ++i) {
      Fmu* f = &h->fmus[i];
      if (f->c == NULL) continue;
      h->failed |= f->scheduled ? schedule(h, i, k) : step(h, i, k);
      h->failed |= print_outputs(&h->out, f, i, k);
    }
  }
  for (i = 0; i < h->n_fmus; ++i) {
    if (h->fmus[i].c != NULL) {
      h->fmus[i].terminate(h->fmus[i].c);
      h->fmus[i].free_instance(h->fmus[i].c);
    }
    LIB_CLOSE(h->fmus[i].lib);
  }
  if (h->record != NULL) fclose(h->record);
  free(h->replay);
  printf("ticks %ld failed %d locks %ld preemptions %ld\n", k, h->failed, h->locks, h->preemptions);
  return h->failed ? 1 : 0;
}
