/* A small FMI 3.0 co-simulation master in C, written from the standard's call sequences (FMI 3.0.2, sections
   "Co-Simulation" and "Clocks"), with no Python in the process: a second importer for the clocked loop.

   It loads every FMU binary named in a plan file, sets the parameters in Initialization Mode, reads every
   output it needs there (clocked outputs are accessible in Initialization Mode), and steps the instances in
   file order on a fixed tick (Gauss-Seidel). For an instance with periodic input clocks, at every tick where
   one of them is due (k >= shift and (k - shift) % interval == 0, in ticks) it runs Event Mode: set the inputs,
   fmi3SetClock(the due clocks), set their clocked inputs, get their clocked outputs, fmi3UpdateDiscreteStates
   until no further update, fmi3EnterStepMode; the first tick uses the Event Mode that follows
   fmi3ExitInitializationMode. Then fmi3DoStep and the outputs that are not clocked. An FMU that reports
   eventHandlingNeeded gets an Event Mode at the next tick even when no clock is due.

   usage: fmi3_loop_host PLAN
   PLAN is text, one item a line:
     F name binary token           an FMU instance (stepping order = file order)
     K name vr interval shift      one of its periodic input clocks (interval and shift in ticks)
     V name vr clockvr             one of its variables (input or output) clocked by that clock
     P name R|I|B|S vr value       a parameter or start value (S: the rest of the line)
     C src R|I|B vr dst vr         a connection from src's output to dst's input
     T tick ticks                  the tick (s) and how many to run
     O name vr                     a Float64 output printed after every tick ("k name vr value", C99 hex float); a
                                   clocked one as read at its clock's last tick
   Exit 0 when every call succeeded. Portable: dlopen on POSIX, LoadLibrary on Windows (run under wine here). */
#include "fmi3_host_common.h"

/* Read the sources' outputs of the links from f: which = 0 the non-clocked, 1 the clocked ones of due clocks, 2 all. */
static int read_outputs(Fmu* fmus, int fi, Link* links, int n_links, int which, const int* due) {
  int j, failed = 0;
  Fmu* f = &fmus[fi];
  for (j = 0; j < n_links; ++j) {
    Link* l = &links[j];
    fmi3ValueReference clock;
    if (l->src != fi) continue;
    clock = clock_of(f, l->src_vr);
    if ((which == 0 && clock) || (which == 1 && (!clock || !is_due(f, clock, due)))) continue;
    if (l->type == 'R') failed |= f->get_float64(f->c, &l->src_vr, 1, &l->real, 1) != fmi3OK;
    else if (l->type == 'I') failed |= f->get_int32(f->c, &l->src_vr, 1, &l->integer, 1) != fmi3OK;
    else failed |= f->get_boolean(f->c, &l->src_vr, 1, &l->boolean, 1) != fmi3OK;
  }
  return failed;
}

/* Set f's connected inputs: which = 0 the non-clocked ones, 1 those clocked by a due clock. */
static int set_inputs(Fmu* fmus, int fi, Link* links, int n_links, int which, const int* due) {
  int j, failed = 0;
  Fmu* f = &fmus[fi];
  for (j = 0; j < n_links; ++j) {
    Link* l = &links[j];
    fmi3ValueReference clock;
    if (l->dst != fi) continue;
    clock = clock_of(f, l->dst_vr);
    if ((which == 0 && clock) || (which == 1 && (!clock || !is_due(f, clock, due)))) continue;
    if (l->type == 'R') failed |= f->set_float64(f->c, &l->dst_vr, 1, &l->real, 1) != fmi3OK;
    else if (l->type == 'I') failed |= f->set_int32(f->c, &l->dst_vr, 1, &l->integer, 1) != fmi3OK;
    else failed |= f->set_boolean(f->c, &l->dst_vr, 1, &l->boolean, 1) != fmi3OK;
  }
  return failed;
}

/* Event Mode at tick k for the due clocks (the FMU is in Step Mode unless this is the first event). */
static int event_mode(Fmu* fmus, int fi, Link* links, int n_links, Outputs* out, const int* due) {
  Fmu* f = &fmus[fi];
  int j, failed = 0;
  if (!f->in_event) failed |= f->enter_event(f->c) != fmi3OK;
  failed |= set_inputs(fmus, fi, links, n_links, 0, due);
  failed |= set_due_clocks(f, due);
  failed |= set_inputs(fmus, fi, links, n_links, 1, due);
  failed |= read_outputs(fmus, fi, links, n_links, 1, due); /* before the update: it deactivates the clocks */
  for (j = 0; j < out->n; ++j) {
    fmi3ValueReference clock = clock_of(f, out->vr[j]);
    if (out->fmu[j] == fi && clock && is_due(f, clock, due))
      failed |= f->get_float64(f->c, &out->vr[j], 1, &out->held[j], 1) != fmi3OK;
  }
  return leave_event_mode(f, failed);
}

int main(int argc, char** argv) {
  static Fmu fmus[MAX_FMUS];
  static Link links[MAX_LINKS];
  static Outputs out;
  static char params[MAX_PARAMS][512];
  char line[4096], name[64], other[64], binary[2048], type;
  int n_fmus = 0, n_links = 0, n_params = 0, failed = 0, i;
  double tick = 0.0;
  long ticks = 0, k;
  FILE* plan;
  if (argc != 2 || (plan = fopen(argv[1], "r")) == NULL) {
    fprintf(stderr, "usage: %s PLAN\n", argv[0]);
    return 2;
  }
  while (fgets(line, sizeof line, plan)) {
    unsigned a, b;
    long p, q;
    line[strcspn(line, "\n")] = '\0';
    if (line[0] == 'F' && n_fmus < MAX_FMUS) {
      Fmu* f = &fmus[n_fmus];
      if (sscanf(line, "F %63s %2047s %127s", f->name, binary, f->token) != 3 || load(f, binary, false)) return 1;
      ++n_fmus;
    } else if (line[0] == 'K' && sscanf(line, "K %63s %u %ld %ld", name, &a, &p, &q) == 4) {
      Fmu* f = &fmus[find(fmus, n_fmus, name)];
      f->clocks[f->n_clocks].vr = a;
      f->clocks[f->n_clocks].interval = p;
      f->clocks[f->n_clocks++].shift = q;
    } else if (line[0] == 'V' && sscanf(line, "V %63s %u %u", name, &a, &b) == 3) {
      Fmu* f = &fmus[find(fmus, n_fmus, name)];
      f->clocked_vr[f->n_clocked] = a;
      f->clocked_by[f->n_clocked++] = b;
    } else if (line[0] == 'P' && n_params < MAX_PARAMS) {
      const size_t len = strlen(line);
      if (len >= sizeof params[0]) {
        fprintf(stderr, "plan line too long: %.40s...\n", line);
        return 2;
      }
      memcpy(params[n_params++], line, len + 1); /* set in Initialization Mode, below */
    } else if (line[0] == 'C' && sscanf(line, "C %63s %c %u %63s %u", name, &type, &a, other, &b) == 5) {
      Link* l = &links[n_links++];
      l->src = find(fmus, n_fmus, name);
      l->dst = find(fmus, n_fmus, other);
      l->type = type;
      l->src_vr = a;
      l->dst_vr = b;
    } else if (line[0] == 'T') {
      if (sscanf(line, "T %lf %ld", &tick, &ticks) != 2) return 2;
    } else if (line[0] == 'O' && sscanf(line, "O %63s %u", name, &a) == 2) {
      out.fmu[out.n] = find(fmus, n_fmus, name);
      out.held[out.n] = NAN;
      out.vr[out.n++] = a;
    }
  }
  fclose(plan);
  /* instantiate (eventModeUsed when the FMU has clocks: required then), Initialization Mode, parameters */
  for (i = 0; i < n_fmus; ++i) {
    Fmu* f = &fmus[i];
    f->c = f->instantiate(f->name, f->token, NULL, fmi3False, fmi3False, f->n_clocks > 0, fmi3False, NULL, 0, f->name,
                          log_message, NULL);
    if (f->c == NULL) {
      fprintf(stderr, "%s: fmi3InstantiateCoSimulation failed\n", f->name);
      return 1;
    }
    failed |= f->enter_init(f->c, fmi3False, 0.0, 0.0, fmi3False, 0.0) != fmi3OK;
  }
  for (i = 0; i < n_params; ++i) failed |= set_parameter(fmus, n_fmus, params[i]);
  for (i = 0; i < n_fmus; ++i) {
    int none[MAX_CLOCKS] = {0};
    failed |= read_outputs(fmus, i, links, n_links, 2, none); /* every output, clocked ones too: Initialization Mode */
    failed |= fmus[i].exit_init(fmus[i].c) != fmi3OK;
    fmus[i].in_event = fmus[i].n_clocks > 0; /* eventModeUsed: Event Mode at the start time */
  }
  for (k = 0; k < ticks && !failed; ++k) {
    const double t = (double)k * tick;
    for (i = 0; i < n_fmus && !failed; ++i) {
      Fmu* f = &fmus[i];
      int due[MAX_CLOCKS];
      if (needs_event_mode(f, k, due)) failed |= event_mode(fmus, i, links, n_links, &out, due);
      else failed |= set_inputs(fmus, i, links, n_links, 0, due);
      failed |= step_fmu(f, t, tick);
      failed |= read_outputs(fmus, i, links, n_links, 0, due);
      failed |= print_outputs(&out, f, i, k);
    }
  }
  for (i = 0; i < n_fmus; ++i) {
    fmus[i].terminate(fmus[i].c);
    fmus[i].free_instance(fmus[i].c);
    LIB_CLOSE(fmus[i].lib);
  }
  printf("ticks %ld failed %d\n", k, failed);
  return failed ? 1 : 0;
}
