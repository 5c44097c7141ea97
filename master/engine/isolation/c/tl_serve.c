/* tl_serve: one FMI 2.0 co-simulation FMU served to a tiltload master over TCP, in C99 with no Python: the board side
   of `tiltload run --remote` where only a C library runs (docs/mil_sil_pil.md). Cross-built for aarch64 and run under
   qemu-user, it is processor-in-the-loop: the FMU's aarch64 binary stepped in an aarch64 process.

   usage: tl_serve --fmu-dir DIR --token-file FILE [--bind HOST:PORT] [--sessions N]
   DIR is the unpacked FMU (modelDescription.xml, binaries/<platform>/<id>.so, resources/). It listens (port 0: a free
   one), prints "listening on HOST:PORT" on stdout, and serves one master at a time, N sessions (0, the default: until
   killed). Per session the protocol of master/engine/isolation: the HMAC handshake (handshake.py), the request for the
   FMU by model identifier and GUID, then the messages of wire.py (S steps in raw bytes, J requests in JSON, O replies),
   every frame a little-endian uint32 length and its bytes. What it does not do: FMU states (get_state is refused), FMI
   3.0, more than one session at a time; the Python server (`tiltload serve`) does those. */
#define _XOPEN_SOURCE 700
#include <arpa/inet.h>
#include <dlfcn.h>
#include <errno.h>
#include <netdb.h>
#include <netinet/in.h>
#include <netinet/tcp.h>
#include <stdarg.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/socket.h>
#include <unistd.h>

#include "fmi2Functions.h"

#if defined(__aarch64__)
#define PLATFORM "aarch64-linux"
#elif defined(__x86_64__)
#define PLATFORM "linux64"
#else
#error "tl_serve: unknown platform (aarch64-linux or linux64)"
#endif

#define MAGIC "tiltload-remote/1\n"
#define MAGIC_LEN 18
#define NONCE 32
#define PROTOCOL 3 /* handshake.PROTOCOL: 3 sends the connected inputs with the init request */
#define FRAME_LIMIT (1u << 20)
#define LOG_LIMIT (64 * 1024)

/* ---------- SHA-256 and HMAC (FIPS 180-4, RFC 2104): the handshake's MAC ---------- */

typedef struct {
  uint32_t h[8];
  uint64_t bytes;
  unsigned char block[64];
  size_t used;
} Sha256;

static const uint32_t K256[64] = {
    0x428a2f98, 0x71374491, 0xb5c0fbcf, 0xe9b5dba5, 0x3956c25b, 0x59f111f1, 0x923f82a4, 0xab1c5ed5, 0xd807aa98, 0x12835b01,
    0x243185be, 0x550c7dc3, 0x72be5d74, 0x80deb1fe, 0x9bdc06a7, 0xc19bf174, 0xe49b69c1, 0xefbe4786, 0x0fc19dc6, 0x240ca1cc,
    0x2de92c6f, 0x4a7484aa, 0x5cb0a9dc, 0x76f988da, 0x983e5152, 0xa831c66d, 0xb00327c8, 0xbf597fc7, 0xc6e00bf3, 0xd5a79147,
    0x06ca6351, 0x14292967, 0x27b70a85, 0x2e1b2138, 0x4d2c6dfc, 0x53380d13, 0x650a7354, 0x766a0abb, 0x81c2c92e, 0x92722c85,
    0xa2bfe8a1, 0xa81a664b, 0xc24b8b70, 0xc76c51a3, 0xd192e819, 0xd6990624, 0xf40e3585, 0x106aa070, 0x19a4c116, 0x1e376c08,
    0x2748774c, 0x34b0bcb5, 0x391c0cb3, 0x4ed8aa4a, 0x5b9cca4f, 0x682e6ff3, 0x748f82ee, 0x78a5636f, 0x84c87814, 0x8cc70208,
    0x90befffa, 0xa4506ceb, 0xbef9a3f7, 0xc67178f2};

#define ROR(x, n) (((x) >> (n)) | ((x) << (32 - (n))))

static void sha_block(Sha256* s, const unsigned char* p) {
  uint32_t w[64], a, b, c, d, e, f, g, h, t1, t2;
  int i;
  for (i = 0; i < 16; ++i) w[i] = (uint32_t)p[4 * i] << 24 | (uint32_t)p[4 * i + 1] << 16 | (uint32_t)p[4 * i + 2] << 8 | p[4 * i + 3];
  for (i = 16; i < 64; ++i) {
    uint32_t s0 = ROR(w[i - 15], 7) ^ ROR(w[i - 15], 18) ^ (w[i - 15] >> 3);
    uint32_t s1 = ROR(w[i - 2], 17) ^ ROR(w[i - 2], 19) ^ (w[i - 2] >> 10);
    w[i] = w[i - 16] + s0 + w[i - 7] + s1;
  }
  a = s->h[0], b = s->h[1], c = s->h[2], d = s->h[3], e = s->h[4], f = s->h[5], g = s->h[6], h = s->h[7];
  for (i = 0; i < 64; ++i) {
    t1 = h + (ROR(e, 6) ^ ROR(e, 11) ^ ROR(e, 25)) + ((e & f) ^ (~e & g)) + K256[i] + w[i];
    t2 = (ROR(a, 2) ^ ROR(a, 13) ^ ROR(a, 22)) + ((a & b) ^ (a & c) ^ (b & c));
    h = g, g = f, f = e, e = d + t1, d = c, c = b, b = a, a = t1 + t2;
  }
  s->h[0] += a, s->h[1] += b, s->h[2] += c, s->h[3] += d, s->h[4] += e, s->h[5] += f, s->h[6] += g, s->h[7] += h;
}

static void sha_init(Sha256* s) {
  static const uint32_t h0[8] = {0x6a09e667, 0xbb67ae85, 0x3c6ef372, 0xa54ff53a, 0x510e527f, 0x9b05688c, 0x1f83d9ab, 0x5be0cd19};
  memcpy(s->h, h0, sizeof h0);
  s->bytes = 0;
  s->used = 0;
}

static void sha_update(Sha256* s, const void* data, size_t n) {
  const unsigned char* p = (const unsigned char*)data;
  s->bytes += n;
  while (n--) {
    s->block[s->used++] = *p++;
    if (s->used == 64) {
      sha_block(s, s->block);
      s->used = 0;
    }
  }
}

static void sha_final(Sha256* s, unsigned char out[32]) {
  uint64_t bits = s->bytes * 8;
  unsigned char pad = 0x80, zero = 0, len[8];
  int i;
  sha_update(s, &pad, 1);
  while (s->used != 56) sha_update(s, &zero, 1);
  for (i = 0; i < 8; ++i) len[i] = (unsigned char)(bits >> (56 - 8 * i));
  sha_update(s, len, 8);
  for (i = 0; i < 8; ++i) {
    out[4 * i] = (unsigned char)(s->h[i] >> 24), out[4 * i + 1] = (unsigned char)(s->h[i] >> 16);
    out[4 * i + 2] = (unsigned char)(s->h[i] >> 8), out[4 * i + 3] = (unsigned char)s->h[i];
  }
}

/* HMAC-SHA256(key, role || first || second), as handshake._mac. */
static void hmac(const unsigned char* key, size_t key_len, const char* role, const unsigned char* first,
                 const unsigned char* second, unsigned char out[32]) {
  unsigned char k[64], pad[64], inner[32];
  Sha256 s;
  int i;
  memset(k, 0, sizeof k);
  if (key_len > 64) {
    sha_init(&s);
    sha_update(&s, key, key_len);
    sha_final(&s, k);
  } else {
    memcpy(k, key, key_len);
  }
  for (i = 0; i < 64; ++i) pad[i] = k[i] ^ 0x36;
  sha_init(&s);
  sha_update(&s, pad, 64);
  sha_update(&s, role, strlen(role));
  sha_update(&s, first, NONCE);
  sha_update(&s, second, NONCE);
  sha_final(&s, inner);
  for (i = 0; i < 64; ++i) pad[i] = k[i] ^ 0x5c;
  sha_init(&s);
  sha_update(&s, pad, 64);
  sha_update(&s, inner, 32);
  sha_final(&s, out);
}

/* ---------- the link: whole reads and writes, frames ---------- */

static int read_all(int fd, void* buf, size_t n) {
  unsigned char* p = (unsigned char*)buf;
  while (n) {
    ssize_t got = read(fd, p, n);
    if (got < 0 && errno == EINTR) continue;
    if (got <= 0) return -1;
    p += got, n -= (size_t)got;
  }
  return 0;
}

static int write_all(int fd, const void* buf, size_t n) {
  const unsigned char* p = (const unsigned char*)buf;
  while (n) {
    ssize_t put = write(fd, p, n);
    if (put < 0 && errno == EINTR) continue;
    if (put <= 0) return -1;
    p += put, n -= (size_t)put;
  }
  return 0;
}

/* A growing byte buffer: a frame being built. */
typedef struct {
  unsigned char* data;
  size_t size, cap;
} Bytes;

static void put(Bytes* b, const void* data, size_t n) {
  if (b->size + n > b->cap) {
    size_t cap = b->cap ? b->cap : 256;
    while (cap < b->size + n) cap *= 2;
    b->data = (unsigned char*)realloc(b->data, cap);
    if (!b->data) {
      fprintf(stderr, "tl_serve: out of memory\n");
      exit(1);
    }
    b->cap = cap;
  }
  memcpy(b->data + b->size, data, n);
  b->size += n;
}

static void puts_(Bytes* b, const char* text) { put(b, text, strlen(text)); }

static int send_frame(int fd, const Bytes* b) {
  unsigned char head[4];
  uint32_t n = (uint32_t)b->size;
  head[0] = (unsigned char)n, head[1] = (unsigned char)(n >> 8), head[2] = (unsigned char)(n >> 16), head[3] = (unsigned char)(n >> 24);
  return write_all(fd, head, 4) || write_all(fd, b->data, b->size);
}

/* The next frame into *b (NUL-terminated past its end); -1 when the link ends or the frame is too large. */
static int receive_frame(int fd, Bytes* b) {
  unsigned char head[4];
  uint32_t n;
  if (read_all(fd, head, 4)) return -1;
  n = (uint32_t)head[0] | (uint32_t)head[1] << 8 | (uint32_t)head[2] << 16 | (uint32_t)head[3] << 24;
  if (n > FRAME_LIMIT) {
    fprintf(stderr, "tl_serve: refused a frame of %u bytes (at most %u)\n", n, FRAME_LIMIT);
    return -1;
  }
  b->size = 0;
  if (b->cap < (size_t)n + 1) {
    b->data = (unsigned char*)realloc(b->data, (size_t)n + 1);
    if (!b->data) return -1;
    b->cap = (size_t)n + 1;
  }
  if (read_all(fd, b->data, n)) return -1;
  b->size = n;
  b->data[n] = 0;
  return 0;
}

/* ---------- JSON: the flat objects of the J messages ---------- */

typedef enum { J_NONE, J_NUMBER, J_BOOL, J_STRING, J_NULL, J_OBJECT } JsonKind;

typedef struct {
  JsonKind kind;
  double number;
  int boolean;
  char* string; /* J_STRING: decoded, malloc'd; J_OBJECT: the object's text (from its '{'), not owned */
} JsonValue;

static const char* skip_space(const char* p) {
  while (*p == ' ' || *p == '\t' || *p == '\n' || *p == '\r') ++p;
  return p;
}

static void put_utf8(Bytes* b, unsigned code) {
  unsigned char u[4];
  if (code < 0x80) {
    u[0] = (unsigned char)code;
    put(b, u, 1);
  } else if (code < 0x800) {
    u[0] = (unsigned char)(0xc0 | code >> 6), u[1] = (unsigned char)(0x80 | (code & 0x3f));
    put(b, u, 2);
  } else {
    u[0] = (unsigned char)(0xe0 | code >> 12), u[1] = (unsigned char)(0x80 | ((code >> 6) & 0x3f));
    u[2] = (unsigned char)(0x80 | (code & 0x3f));
    put(b, u, 3);
  }
}

/* A string at p (its opening quote): decoded into *out (malloc'd); the position after it, NULL if malformed. */
static const char* parse_string(const char* p, char** out) {
  Bytes b = {NULL, 0, 0};
  char nul = 0;
  if (*p++ != '"') return NULL;
  while (*p && *p != '"') {
    if (*p == '\\') {
      char e = *++p;
      if (e == 'u') {
        unsigned code = 0;
        int i;
        for (i = 1; i <= 4; ++i) {
          char h = p[i];
          code = code * 16 + (unsigned)(h >= '0' && h <= '9' ? h - '0' : h >= 'a' && h <= 'f' ? h - 'a' + 10 : h >= 'A' && h <= 'F' ? h - 'A' + 10 : 0);
          if (!h) return free(b.data), NULL;
        }
        put_utf8(&b, code);
        p += 5;
        continue;
      }
      e = e == 'n' ? '\n' : e == 't' ? '\t' : e == 'r' ? '\r' : e == 'b' ? '\b' : e == 'f' ? '\f' : e;
      if (!e) return free(b.data), NULL;
      put(&b, &e, 1);
      ++p;
    } else {
      put(&b, p++, 1);
    }
  }
  if (*p != '"') return free(b.data), NULL;
  put(&b, &nul, 1);
  *out = (char*)b.data;
  return p + 1;
}

/* The value at p; objects are skipped over (their text kept), arrays refused. */
static const char* parse_value(const char* p, JsonValue* v) {
  p = skip_space(p);
  v->kind = J_NONE;
  v->string = NULL;
  if (*p == '"') {
    v->kind = J_STRING;
    return parse_string(p, &v->string);
  }
  if (!strncmp(p, "true", 4) || !strncmp(p, "false", 5)) {
    v->kind = J_BOOL;
    v->boolean = *p == 't';
    return p + (v->boolean ? 4 : 5);
  }
  if (!strncmp(p, "null", 4)) {
    v->kind = J_NULL;
    return p + 4;
  }
  if (*p == '{') {
    int depth = 0;
    const char* start = p;
    do {
      if (*p == '"') {
        char* skipped = NULL;
        p = parse_string(p, &skipped);
        free(skipped);
        if (!p) return NULL;
        continue;
      }
      if (*p == '{') ++depth;
      if (*p == '}') --depth;
      if (!*p || *p == '[') return NULL;
      ++p;
    } while (depth > 0);
    v->kind = J_OBJECT;
    v->string = (char*)start;
    return p;
  }
  {
    char* end;
    v->number = strtod(p, &end);
    if (end == p) return NULL;
    v->kind = J_NUMBER;
    return end;
  }
}

/* Calls each(key, value, context) for the members of the object at text; 0, or -1 if it is malformed. */
static int each_member(const char* text, int (*each)(const char*, JsonValue*, void*), void* context) {
  const char* p = skip_space(text);
  if (*p++ != '{') return -1;
  p = skip_space(p);
  if (*p == '}') return 0;
  for (;;) {
    char* key = NULL;
    JsonValue v;
    int status;
    p = parse_string(skip_space(p), &key);
    if (!p) return -1;
    p = skip_space(p);
    if (*p++ != ':' || !(p = parse_value(p, &v))) return free(key), -1;
    status = each(key, &v, context);
    free(key);
    if (v.kind == J_STRING) free(v.string);
    if (status) return status;
    p = skip_space(p);
    if (*p == '}') return 0;
    if (*p++ != ',') return -1;
  }
}

static void put_json_string(Bytes* b, const char* s) {
  char esc[8];
  puts_(b, "\"");
  for (; *s; ++s) {
    unsigned char c = (unsigned char)*s;
    if (c == '"' || c == '\\') {
      esc[0] = '\\', esc[1] = (char)c;
      put(b, esc, 2);
    } else if (c < 0x20) {
      snprintf(esc, sizeof esc, "\\u%04x", c);
      puts_(b, esc);
    } else {
      put(b, &c, 1);
    }
  }
  puts_(b, "\"");
}

/* ---------- the model: what modelDescription.xml says ---------- */

enum { T_REAL, T_INTEGER, T_BOOLEAN, T_STRING, T_OTHER };

typedef struct {
  char* name;
  unsigned vr;
  int type;
  char causality[16];
} Variable;

typedef struct {
  char *guid, *identifier;
  Variable* vars;
  int n;
} Model;

static char* read_file(const char* path, size_t* size) {
  FILE* f = fopen(path, "rb");
  char* text;
  long n;
  if (!f) return NULL;
  fseek(f, 0, SEEK_END);
  n = ftell(f);
  fseek(f, 0, SEEK_SET);
  text = (char*)malloc((size_t)n + 1);
  if (text && fread(text, 1, (size_t)n, f) != (size_t)n) {
    free(text);
    text = NULL;
  }
  fclose(f);
  if (text) text[n] = 0;
  if (size) *size = (size_t)n;
  return text;
}

/* The value of attribute name in the tag from start to end (exclusive), XML entities decoded; NULL if absent. */
static char* attribute(const char* start, const char* end, const char* name) {
  size_t len = strlen(name);
  const char* p = start;
  while ((p = strstr(p, name)) && p < end) {
    if ((p[-1] == ' ' || p[-1] == '\n' || p[-1] == '\t' || p[-1] == '\r') && p[len] == '=' && p[len + 1] == '"') {
      const char* v = p + len + 2;
      const char* q = strchr(v, '"');
      Bytes b = {NULL, 0, 0};
      char nul = 0;
      if (!q || q > end) return NULL;
      while (v < q) {
        static const char* entities[][2] = {{"&amp;", "&"}, {"&lt;", "<"}, {"&gt;", ">"}, {"&quot;", "\""}, {"&apos;", "'"}};
        size_t i, done = 0;
        for (i = 0; i < 5 && !done; ++i)
          if (!strncmp(v, entities[i][0], strlen(entities[i][0]))) {
            put(&b, entities[i][1], 1);
            v += strlen(entities[i][0]);
            done = 1;
          }
        if (!done) put(&b, v++, 1);
      }
      put(&b, &nul, 1);
      return (char*)b.data;
    }
    p += len;
  }
  return NULL;
}

static int read_model(const char* dir, Model* m) {
  char path[4096];
  char *xml, *p, *end;
  int cap = 64;
  snprintf(path, sizeof path, "%s/modelDescription.xml", dir);
  xml = read_file(path, NULL);
  if (!xml) return fprintf(stderr, "tl_serve: cannot read %s\n", path), -1;
  p = strstr(xml, "<fmiModelDescription");
  end = p ? strchr(p, '>') : NULL;
  m->guid = p && end ? attribute(p, end, "guid") : NULL;
  p = strstr(xml, "<CoSimulation");
  end = p ? strchr(p, '>') : NULL;
  m->identifier = p && end ? attribute(p, end, "modelIdentifier") : NULL;
  if (!m->guid || !m->identifier) return fprintf(stderr, "tl_serve: %s names no GUID or co-simulation model\n", path), -1;
  m->vars = (Variable*)malloc(sizeof(Variable) * (size_t)cap);
  m->n = 0;
  p = xml;
  while ((p = strstr(p, "<ScalarVariable"))) {
    char *vr, *causality, *type;
    Variable* v;
    end = strchr(p, '>');
    if (!end) break;
    if (m->n == cap) m->vars = (Variable*)realloc(m->vars, sizeof(Variable) * (size_t)(cap *= 2));
    v = &m->vars[m->n++];
    v->name = attribute(p, end, "name");
    vr = attribute(p, end, "valueReference");
    causality = attribute(p, end, "causality");
    snprintf(v->causality, sizeof v->causality, "%s", causality ? causality : "local");
    v->vr = vr ? (unsigned)strtoul(vr, NULL, 10) : 0;
    type = strchr(end + 1, '<');
    v->type = !type ? T_OTHER : !strncmp(type, "<Real", 5) ? T_REAL : !strncmp(type, "<Integer", 8) ? T_INTEGER
            : !strncmp(type, "<Boolean", 8) ? T_BOOLEAN : !strncmp(type, "<String", 7) ? T_STRING
            : !strncmp(type, "<Enumeration", 12) ? T_INTEGER : T_OTHER;
    free(vr);
    free(causality);
    if (!v->name) return fprintf(stderr, "tl_serve: a variable without a name in %s\n", path), -1;
    p = end;
  }
  free(xml);
  return 0;
}

static Variable* find_variable(const Model* m, const char* name) {
  int i;
  for (i = 0; i < m->n; ++i)
    if (!strcmp(m->vars[i].name, name)) return &m->vars[i];
  return NULL;
}

/* ---------- the FMU ---------- */

typedef struct {
  fmi2InstantiateTYPE* instantiate;
  fmi2FreeInstanceTYPE* free_instance;
  fmi2SetupExperimentTYPE* setup;
  fmi2EnterInitializationModeTYPE* enter;
  fmi2ExitInitializationModeTYPE* exit_init;
  fmi2TerminateTYPE* terminate;
  fmi2ResetTYPE* reset;
  fmi2SetRealTYPE* set_real;
  fmi2SetIntegerTYPE* set_integer;
  fmi2SetBooleanTYPE* set_boolean;
  fmi2SetStringTYPE* set_string;
  fmi2GetRealTYPE* get_real;
  fmi2GetIntegerTYPE* get_integer;
  fmi2GetBooleanTYPE* get_boolean;
  fmi2DoStepTYPE* do_step;
} Api;

typedef struct {
  Model model;
  Api api;
  fmi2Component c;
  unsigned* out_vr[3];
  int n_out[3];
  Bytes log; /* the FMU's log lines since the last reply, as JSON strings joined by commas */
  int log_lines;
  int fatal;
} Fmu;

static Fmu* current; /* the logger's instance: one FMU a process */

static void logger(fmi2ComponentEnvironment env, fmi2String name, fmi2Status status, fmi2String category, fmi2String message, ...) {
  char text[4096];
  va_list args;
  (void)env, (void)name, (void)status, (void)category;
  if (!current || current->log.size > LOG_LIMIT) return;
  va_start(args, message);
  vsnprintf(text, sizeof text, message, args);
  va_end(args);
  if (current->log_lines++) puts_(&current->log, ",");
  put_json_string(&current->log, text);
}

#define BIND(field, name) (*(void**)(&api->field) = dlsym(lib, name)) == NULL

static int load_api(void* lib, Api* api) {
  return BIND(instantiate, "fmi2Instantiate") || BIND(free_instance, "fmi2FreeInstance") || BIND(setup, "fmi2SetupExperiment") ||
         BIND(enter, "fmi2EnterInitializationMode") || BIND(exit_init, "fmi2ExitInitializationMode") ||
         BIND(terminate, "fmi2Terminate") || BIND(reset, "fmi2Reset") || BIND(set_real, "fmi2SetReal") ||
         BIND(set_integer, "fmi2SetInteger") || BIND(set_boolean, "fmi2SetBoolean") || BIND(set_string, "fmi2SetString") ||
         BIND(get_real, "fmi2GetReal") || BIND(get_integer, "fmi2GetInteger") || BIND(get_boolean, "fmi2GetBoolean") ||
         BIND(do_step, "fmi2DoStep");
}

/* ---------- replies ---------- */

static void put_log(Bytes* b, Fmu* f) {
  puts_(b, "[");
  if (f->log.size) put(b, f->log.data, f->log.size);
  puts_(b, "]");
  f->log.size = 0;
  f->log_lines = 0;
}

static int reply_ok(int fd, Fmu* f) {
  Bytes b = {NULL, 0, 0};
  int status;
  puts_(&b, "J{\"ok\": true, \"log\": ");
  put_log(&b, f);
  puts_(&b, "}");
  status = send_frame(fd, &b);
  free(b.data);
  return status;
}

static int reply_error(int fd, Fmu* f, const char* kind, const char* fmt, ...) {
  Bytes b = {NULL, 0, 0};
  char message[1024];
  va_list args;
  int status;
  va_start(args, fmt);
  vsnprintf(message, sizeof message, fmt, args);
  va_end(args);
  puts_(&b, "J{\"error\": ");
  put_json_string(&b, kind);
  puts_(&b, ", \"message\": ");
  put_json_string(&b, message);
  puts_(&b, f->fatal ? ", \"fatal\": true, \"log\": " : ", \"fatal\": false, \"log\": ");
  put_log(&b, f);
  puts_(&b, "}");
  status = send_frame(fd, &b);
  free(b.data);
  return status;
}

/* The outputs in wire.py's layout: Reals as float64, Integers and Booleans as int32, little-endian (this host's). */
static int reply_outputs(int fd, Fmu* f) {
  Bytes b = {NULL, 0, 0};
  double reals[4096];
  fmi2Integer ints[4096];
  int status = 0;
  puts_(&b, "O");
  if (f->n_out[0] && f->api.get_real(f->c, f->out_vr[0], (size_t)f->n_out[0], reals) > fmi2Warning) status = -1;
  put(&b, reals, sizeof(double) * (size_t)f->n_out[0]);
  if (f->n_out[1] && f->api.get_integer(f->c, f->out_vr[1], (size_t)f->n_out[1], ints) > fmi2Warning) status = -1;
  put(&b, ints, sizeof(fmi2Integer) * (size_t)f->n_out[1]);
  if (f->n_out[2] && f->api.get_boolean(f->c, f->out_vr[2], (size_t)f->n_out[2], ints) > fmi2Warning) status = -1;
  put(&b, ints, sizeof(fmi2Integer) * (size_t)f->n_out[2]);
  if (status) {
    free(b.data);
    return reply_error(fd, f, "execution", "%s: reading the outputs failed", f->model.identifier);
  }
  if (f->log_lines) put_log(&b, f);
  status = send_frame(fd, &b);
  free(b.data);
  return status;
}

/* ---------- requests ---------- */

typedef struct {
  Fmu* f;
  char problem[512];
} SetContext;

static int set_one(const char* name, JsonValue* v, void* context) {
  SetContext* s = (SetContext*)context;
  Fmu* f = s->f;
  Variable* var = find_variable(&f->model, name);
  fmi2Status status = fmi2Error;
  if (!var) return snprintf(s->problem, sizeof s->problem, "unknown variable '%s'", name), 1;
  if (var->type == T_REAL && (v->kind == J_NUMBER || v->kind == J_BOOL)) {
    fmi2Real x = v->kind == J_NUMBER ? v->number : v->boolean;
    status = f->api.set_real(f->c, &var->vr, 1, &x);
  } else if (var->type == T_INTEGER && (v->kind == J_NUMBER || v->kind == J_BOOL)) {
    fmi2Integer x = v->kind == J_NUMBER ? (fmi2Integer)v->number : v->boolean;
    status = f->api.set_integer(f->c, &var->vr, 1, &x);
  } else if (var->type == T_BOOLEAN && (v->kind == J_NUMBER || v->kind == J_BOOL)) {
    fmi2Boolean x = v->kind == J_NUMBER ? v->number != 0.0 : v->boolean;
    status = f->api.set_boolean(f->c, &var->vr, 1, &x);
  } else if (var->type == T_STRING && v->kind == J_STRING) {
    fmi2String x = v->string;
    status = f->api.set_string(f->c, &var->vr, 1, &x);
  } else {
    return snprintf(s->problem, sizeof s->problem, "%s: a value of the wrong type", name), 1;
  }
  if (status > fmi2Warning) {
    f->fatal = status == fmi2Fatal;
    return snprintf(s->problem, sizeof s->problem, "setting %s failed (status %d)", name, (int)status), 1;
  }
  return 0;
}

typedef struct {
  char op[32];
  const char* object; /* "parameters" or "values": the object's text */
  char* inputs;       /* init: the connected inputs, base64 of a step's sets (owned), or NULL */
  const char* texts;  /* init: the connected String inputs, an object's text, or NULL */
  double start;       /* init: the start time */
  int bad;            /* a member of the wrong kind or value */
} Request;

static int read_request(const char* key, JsonValue* v, void* context) {
  Request* r = (Request*)context;
  if (!strcmp(key, "op") && v->kind == J_STRING) snprintf(r->op, sizeof r->op, "%s", v->string);
  if ((!strcmp(key, "parameters") || !strcmp(key, "values")) && v->kind == J_OBJECT) r->object = v->string;
  if (!strcmp(key, "inputs")) {
    if (v->kind != J_STRING || r->inputs != NULL) return r->bad = 1, 0;
    r->inputs = v->string; /* taken over: each_member frees a string it still holds only */
    v->kind = J_NONE;
  }
  if (!strcmp(key, "texts")) {
    if (v->kind != J_OBJECT) return r->bad = 1, 0;
    r->texts = v->string;
  }
  if (!strcmp(key, "start")) {
    if (v->kind != J_NUMBER || !(v->number >= 0 && v->number < 1e300)) return r->bad = 1, 0;
    r->start = v->number;
  }
  return 0;
}

/* Standard base64 (RFC 4648, with padding) into out (room for at least 3/4 of the text); its length, or -1. */
static long from_base64(const char* text, unsigned char* out) {
  static const char alphabet[] = "ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";
  size_t len = strlen(text), i;
  long n = 0;
  if (len % 4) return -1;
  for (i = 0; i < len; i += 4) {
    unsigned v = 0;
    int j, pad = 0;
    for (j = 0; j < 4; ++j) {
      const char* at = text[i + j] == '=' ? NULL : strchr(alphabet, text[i + j]);
      if (text[i + j] == '=') {
        if (i + 4 != len || j < 2) return -1;
        ++pad;
      } else if (at == NULL || text[i + j] == 0 || pad) {
        return -1;
      }
      v = v << 6 | (unsigned)(at ? at - alphabet : 0);
    }
    out[n++] = (unsigned char)(v >> 16);
    if (pad < 2) out[n++] = (unsigned char)(v >> 8 & 0xff);
    if (pad < 1) out[n++] = (unsigned char)(v & 0xff);
  }
  return n;
}

static int is_input(const Fmu* f, int type, unsigned vr) {
  int i;
  for (i = 0; i < f->model.n; ++i)
    if (f->model.vars[i].vr == vr && f->model.vars[i].type == type && !strcmp(f->model.vars[i].causality, "input")) return 1;
  return 0;
}

/* A step's sets {code n vrs values} from p to end, each checked against the model, set at time t. 0: all set; else
   what step returns: 1 a protocol error, -1 the link failed, 2 an FMU's failure answered (the session goes on). */
static int apply_sets(int fd, Fmu* f, const unsigned char* p, const unsigned char* end, double t) {
  while (p < end) {
    char code;
    uint32_t n, i;
    int type, width;
    unsigned vrs[512];
    union {
      double r[512];
      fmi2Integer i[512];
    } values;
    fmi2Status status;
    if (p + 5 > end) return reply_error(fd, f, "protocol", "a step ends inside a set's header"), 1;
    code = (char)p[0];
    memcpy(&n, p + 1, 4);
    p += 5;
    type = code == 'R' ? T_REAL : code == 'I' ? T_INTEGER : code == 'B' ? T_BOOLEAN : -1;
    width = type == T_REAL ? 8 : 4;
    if (type < 0) return reply_error(fd, f, "protocol", "a step sets values of unknown type"), 1;
    if (n > 512 || p + (size_t)n * (size_t)(4 + width) > end)
      return reply_error(fd, f, "protocol", "a step announces %u values and ends before them", (unsigned)n), 1;
    memcpy(vrs, p, 4 * (size_t)n);
    memcpy(&values, p + 4 * (size_t)n, (size_t)width * n);
    p += (size_t)n * (size_t)(4 + width);
    for (i = 0; i < n; ++i)
      if (!is_input(f, type, vrs[i])) return reply_error(fd, f, "protocol", "a step sets a variable that is not an input of this model"), 1;
    status = type == T_REAL ? f->api.set_real(f->c, vrs, n, values.r)
           : type == T_INTEGER ? f->api.set_integer(f->c, vrs, n, values.i) : f->api.set_boolean(f->c, vrs, n, values.i);
    if (status > fmi2Warning) {
      f->fatal = status == fmi2Fatal;
      return reply_error(fd, f, "execution", "%s: set%s at t=%.6g s failed", f->model.identifier,
                         type == T_REAL ? "Real" : type == T_INTEGER ? "Integer" : "Boolean", t) ? -1 : 2;
    }
  }
  return 0;
}

/* S t h {code n vrs values}: the sets, then doStep. 1: a protocol error (the session ends), -1: the link failed. */
static int step(int fd, Fmu* f, const Bytes* body) {
  double times[2];
  int failed;
  if (body->size < 17) return reply_error(fd, f, "protocol", "a step of %u bytes is too short", (unsigned)body->size), 1;
  memcpy(times, body->data + 1, 16);
  failed = apply_sets(fd, f, body->data + 17, body->data + body->size, times[0]);
  if (failed) return failed == 2 ? 0 : failed;
  {
    fmi2Status status = f->api.do_step(f->c, times[0], times[1], fmi2True);
    if (status > fmi2Warning) {
      f->fatal = status == fmi2Fatal;
      return reply_error(fd, f, "execution", "%s: doStep at t=%.6g s failed (%s)", f->model.identifier, times[0],
                         status == fmi2Fatal ? "fatal" : status == fmi2Error ? "error" : "discard") ? -1 : 0;
    }
  }
  return reply_outputs(fd, f) ? -1 : 0;
}

/* init: set up at the start time, the parameters and the connected inputs (a step's sets, base64: the master's values
   at the start) set in Initialization Mode, as the master does in its own process; the outputs then. */
static int init(int fd, Fmu* f, const Request* r, SetContext* s) {
  unsigned char* sets = NULL;
  long n = 0;
  int failed;
  if (r->inputs != NULL) {
    sets = malloc(strlen(r->inputs) / 4 * 3 + 3);
    n = sets == NULL ? -1 : from_base64(r->inputs, sets);
    if (n < 17 || sets[0] != 'S') {
      free(sets);
      return reply_error(fd, f, "protocol", "malformed init request (its inputs are not a step's sets)"), 1;
    }
  }
  if (f->api.setup(f->c, fmi2False, 0.0, r->start, fmi2False, 0.0) > fmi2Warning || f->api.enter(f->c) > fmi2Warning) {
    free(sets);
    return reply_error(fd, f, "execution", "%s: entering initialization failed", f->model.identifier) ? -1 : 0;
  }
  if (each_member(r->object, set_one, s)) {
    free(sets);
    return reply_error(fd, f, "execution", "%s: %s", f->model.identifier, s->problem) ? -1 : 0;
  }
  failed = sets != NULL ? apply_sets(fd, f, sets + 17, sets + n, r->start) : 0;
  free(sets);
  if (failed) return failed == 2 ? 0 : failed;
  if (r->texts != NULL && each_member(r->texts, set_one, s))
    return reply_error(fd, f, "execution", "%s: %s", f->model.identifier, s->problem) ? -1 : 0;
  if (f->api.exit_init(f->c) > fmi2Warning)
    return reply_error(fd, f, "execution", "%s: exitInitializationMode failed", f->model.identifier) ? -1 : 0;
  return reply_outputs(fd, f) ? -1 : 0;
}

static int control(int fd, Fmu* f, const Bytes* body) {
  Request r;
  SetContext s;
  memset(&r, 0, sizeof r);
  s.f = f;
  s.problem[0] = 0;
  if (each_member((const char*)body->data + 1, read_request, &r) || r.bad) {
    free(r.inputs);
    return reply_error(fd, f, "protocol", "malformed J message"), 1;
  }
  if (!strcmp(r.op, "init") && r.object) {
    int code = init(fd, f, &r, &s);
    free(r.inputs);
    return code;
  }
  free(r.inputs);
  if (!strcmp(r.op, "set") && r.object) {
    if (each_member(r.object, set_one, &s)) return reply_error(fd, f, "execution", "%s: %s", f->model.identifier, s.problem) ? -1 : 0;
    return reply_ok(fd, f) ? -1 : 0;
  }
  if (!strcmp(r.op, "reset")) {
    if (f->api.reset(f->c) > fmi2Warning) return reply_error(fd, f, "execution", "%s: reset failed", f->model.identifier) ? -1 : 0;
    return reply_ok(fd, f) ? -1 : 0;
  }
  if (!strcmp(r.op, "close")) {
    f->api.terminate(f->c);
    f->api.free_instance(f->c);
    f->c = NULL;
    reply_ok(fd, f);
    return 2;
  }
  return reply_error(fd, f, "protocol", "unknown request '%s' (tl_serve serves no FMU states)", r.op), 1;
}

/* ---------- a session: handshake, the FMU's pick, the messages ---------- */

typedef struct {
  char identifier[256], guid[256], instance[128], byteorder[16];
  int protocol;
} Open;

static int read_open(const char* key, JsonValue* v, void* context) {
  Open* o = (Open*)context;
  if (v->kind == J_NUMBER && !strcmp(key, "protocol")) o->protocol = (int)v->number;
  if (v->kind != J_STRING) return 0;
  if (!strcmp(key, "model_identifier")) snprintf(o->identifier, sizeof o->identifier, "%s", v->string);
  if (!strcmp(key, "guid")) snprintf(o->guid, sizeof o->guid, "%s", v->string);
  if (!strcmp(key, "instance")) snprintf(o->instance, sizeof o->instance, "%s", v->string);
  if (!strcmp(key, "byteorder")) snprintf(o->byteorder, sizeof o->byteorder, "%s", v->string);
  return 0;
}

static int handshake(int fd, const unsigned char* secret, size_t secret_len) {
  unsigned char nonce_s[NONCE], answer[MAGIC_LEN + NONCE + 32], mac[32], reply[33];
  FILE* random = fopen("/dev/urandom", "rb");
  int ok = random && fread(nonce_s, 1, NONCE, random) == NONCE;
  if (random) fclose(random);
  if (!ok) return fprintf(stderr, "tl_serve: no random bytes for the challenge\n"), -1;
  if (write_all(fd, MAGIC, MAGIC_LEN) || write_all(fd, nonce_s, NONCE) || read_all(fd, answer, sizeof answer)) return -1;
  if (memcmp(answer, MAGIC, MAGIC_LEN)) return fprintf(stderr, "tl_serve: refused: not a tiltload client\n"), -1;
  hmac(secret, secret_len, "client", nonce_s, answer + MAGIC_LEN, mac);
  if (memcmp(mac, answer + MAGIC_LEN + NONCE, 32)) {
    unsigned char refused = 0;
    write_all(fd, &refused, 1);
    return fprintf(stderr, "tl_serve: refused: wrong token\n"), -1;
  }
  reply[0] = 1;
  hmac(secret, secret_len, "server", answer + MAGIC_LEN, nonce_s, reply + 1);
  return write_all(fd, reply, sizeof reply);
}

static void serve_session(int fd, const char* dir, Fmu* f, const unsigned char* secret, size_t secret_len) {
  Bytes body = {NULL, 0, 0};
  Open o;
  char location[4200], abs_dir[4096];
  fmi2CallbackFunctions callbacks = {logger, calloc, free, NULL, NULL};
  int status = 0;
  memset(&o, 0, sizeof o);
  if (handshake(fd, secret, secret_len) || receive_frame(fd, &body)) goto done;
  if (body.data[0] != 'J' || each_member((const char*)body.data + 1, read_open, &o)) {
    reply_error(fd, f, "refused", "malformed request for an FMU");
    goto done;
  }
  if (o.protocol != PROTOCOL) {
    reply_error(fd, f, "refused", "protocol %d, this server speaks %d", o.protocol, PROTOCOL);
    goto done;
  }
  if (strcmp(o.byteorder, "little")) {
    reply_error(fd, f, "refused", "the master is %s-endian, this machine little-endian", o.byteorder);
    goto done;
  }
  if (strcmp(o.identifier, f->model.identifier) || strcmp(o.guid, f->model.guid)) {
    reply_error(fd, f, "refused", "no FMU %s %s here (tl_serve serves %s %s)", o.identifier, o.guid, f->model.identifier, f->model.guid);
    goto done;
  }
  fprintf(stderr, "tl_serve: serving %s as %s\n", f->model.identifier, o.instance);
  {
    Bytes b = {NULL, 0, 0};
    puts_(&b, "J{\"ok\": true, \"fmu\": ");
    put_json_string(&b, f->model.identifier);
    puts_(&b, ", \"log\": []}");
    status = send_frame(fd, &b);
    free(b.data);
    if (status) goto done;
  }
  if (!realpath(dir, abs_dir)) snprintf(abs_dir, sizeof abs_dir, "%s", dir);
  snprintf(location, sizeof location, "file://%s/resources", abs_dir);
  f->fatal = 0;
  f->c = f->api.instantiate(o.instance, fmi2CoSimulation, f->model.guid, location, &callbacks, fmi2False, fmi2True);
  if (!f->c) {
    reply_error(fd, f, "execution", "%s: fmi2Instantiate failed", f->model.identifier);
    goto done;
  }
  if (reply_ok(fd, f)) goto done;
  while (status == 0 && receive_frame(fd, &body) == 0 && body.size) {
    if (body.data[0] == 'S')
      status = step(fd, f, &body);
    else if (body.data[0] == 'J')
      status = control(fd, f, &body);
    else
      status = reply_error(fd, f, "protocol", "a message of unknown kind '%c'", body.data[0]) ? -1 : 1;
  }
done:
  if (f->c) {
    if (!f->fatal) f->api.terminate(f->c);
    if (!f->fatal) f->api.free_instance(f->c);
    f->c = NULL;
  }
  free(body.data);
}

static int listen_on(const char* bind_to, char* bound, size_t bound_size) {
  char host[256];
  const char* colon = strrchr(bind_to, ':');
  struct sockaddr_in addr;
  socklen_t len = sizeof addr;
  int fd, one = 1;
  if (!colon || (size_t)(colon - bind_to) >= sizeof host) return -1;
  memcpy(host, bind_to, (size_t)(colon - bind_to));
  host[colon - bind_to] = 0;
  memset(&addr, 0, sizeof addr);
  addr.sin_family = AF_INET;
  addr.sin_port = htons((unsigned short)atoi(colon + 1));
  if (inet_pton(AF_INET, host, &addr.sin_addr) != 1) return -1;
  fd = socket(AF_INET, SOCK_STREAM, 0);
  if (fd < 0) return -1;
  setsockopt(fd, SOL_SOCKET, SO_REUSEADDR, &one, sizeof one);
  if (bind(fd, (struct sockaddr*)&addr, sizeof addr) || listen(fd, 4) || getsockname(fd, (struct sockaddr*)&addr, &len)) {
    close(fd);
    return -1;
  }
  snprintf(bound, bound_size, "%s:%u", host, (unsigned)ntohs(addr.sin_port));
  return fd;
}

static void usage(const char* me) {
  fprintf(stderr, "usage: %s --fmu-dir DIR --token-file FILE [--bind HOST:PORT] [--sessions N]\n", me);
}

int main(int argc, char** argv) {
  const char *dir = NULL, *token = NULL, *bind_to = "127.0.0.1:0";
  char bound[300], path[4400];
  long sessions = 0, served = 0;
  unsigned char* secret;
  size_t secret_len, start = 0;
  void* lib;
  Fmu f;
  int listener, i, t;
  for (i = 1; i + 1 < argc; i += 2) {
    if (!strcmp(argv[i], "--fmu-dir")) dir = argv[i + 1];
    else if (!strcmp(argv[i], "--token-file")) token = argv[i + 1];
    else if (!strcmp(argv[i], "--bind")) bind_to = argv[i + 1];
    else if (!strcmp(argv[i], "--sessions")) sessions = atol(argv[i + 1]);
    else return usage(argv[0]), 2;
  }
  if (i != argc || !dir || !token) return usage(argv[0]), 2;
  secret = (unsigned char*)read_file(token, &secret_len);
  if (!secret) return fprintf(stderr, "tl_serve: cannot read the token file %s\n", token), 2;
  while (secret_len && strchr(" \t\n\r\v\f", secret[secret_len - 1])) --secret_len; /* as bytes.strip() */
  while (start < secret_len && strchr(" \t\n\r\v\f", secret[start])) ++start;
  if (secret_len - start < 16) return fprintf(stderr, "tl_serve: the token file %s holds fewer than 16 bytes\n", token), 2;
  memset(&f, 0, sizeof f);
  current = &f;
  if (read_model(dir, &f.model)) return 2;
  snprintf(path, sizeof path, "%s/binaries/%s/%s.so", dir, PLATFORM, f.model.identifier);
  lib = dlopen(path, RTLD_NOW | RTLD_LOCAL);
  if (!lib) return fprintf(stderr, "tl_serve: cannot load %s: %s\n", path, dlerror()), 2;
  if (load_api(lib, &f.api)) return fprintf(stderr, "tl_serve: %s lacks an FMI 2.0 function\n", path), 2;
  for (i = 0; i < f.model.n; ++i) /* a String output would be neither logged nor connected: said, not dropped */
    if (f.model.vars[i].type == T_STRING && !strcmp(f.model.vars[i].causality, "output"))
      return fprintf(stderr, "tl_serve: %s has a String output; tl_serve serves FMUs whose outputs are numbers and "
                     "Booleans (tiltload serve hosts the others)\n", f.model.identifier), 2;
  for (t = 0; t < 3; ++t) { /* the outputs in model-description order, by type: Real, Integer, Boolean (wire.TYPES) */
    f.out_vr[t] = (unsigned*)malloc(sizeof(unsigned) * (size_t)(f.model.n + 1));
    for (i = 0; i < f.model.n; ++i)
      if (f.model.vars[i].type == t && !strcmp(f.model.vars[i].causality, "output")) f.out_vr[t][f.n_out[t]++] = f.model.vars[i].vr;
  }
  if (f.n_out[0] > 4096 || f.n_out[1] + f.n_out[2] > 4096) return fprintf(stderr, "tl_serve: too many outputs\n"), 2;
  listener = listen_on(bind_to, bound, sizeof bound);
  if (listener < 0) return fprintf(stderr, "tl_serve: cannot listen on %s (an IPv4 HOST:PORT)\n", bind_to), 2;
  printf("listening on %s\n", bound);
  fflush(stdout);
  while (sessions == 0 || served < sessions) {
    int fd = accept(listener, NULL, NULL), one = 1;
    if (fd < 0) {
      if (errno == EINTR) continue;
      break;
    }
    setsockopt(fd, IPPROTO_TCP, TCP_NODELAY, &one, sizeof one);
    serve_session(fd, dir, &f, secret + start, secret_len - start);
    close(fd);
    ++served;
  }
  close(listener);
  return 0;
}
