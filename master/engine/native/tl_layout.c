/* The layout of the structs tl_loop.h shares with kernel.py's ctypes structures, row by row from the same field
   tables that declare them, so the Python side can check its copy when it loads the library (layout.py). */
#include "tl_loop.h"

#include <stddef.h>

#if defined(__GNUC__)
#define TL_EXPORT __attribute__((visibility("default")))
#else
#define TL_EXPORT
#endif

typedef struct {
    const char *structure, *field, *type; /* field NULL: the struct's own row */
    int64_t offset, size;
} tl_layout_row;

/* TL_STRUCT names the struct whose table is being expanded. */
#define TL_STRUCT_ROW(s) {#s, NULL, NULL, 0, (int64_t)sizeof(s)},
#define TL_FIELD_ROW(type, name) \
    {TL_STRUCT_NAME, #name, #type, (int64_t)offsetof(TL_STRUCT, name), (int64_t)sizeof(((TL_STRUCT *)0)->name)},
#define TL_ARRAY_ROW(type, name, length) \
    {TL_STRUCT_NAME, #name, #type "[" #length "]", (int64_t)offsetof(TL_STRUCT, name), (int64_t)sizeof(((TL_STRUCT *)0)->name)},
#define TL_QUOTE(s) #s
#define TL_NAME_OF(s) TL_QUOTE(s) /* s expanded first */
#define TL_STRUCT_NAME TL_NAME_OF(TL_STRUCT)

static const tl_layout_row ROWS[] = {
#define TL_STRUCT tl_group
    TL_STRUCT_ROW(tl_group) TL_GROUP_FIELDS(TL_FIELD_ROW, TL_ARRAY_ROW)
#undef TL_STRUCT
#define TL_STRUCT tl_fault
    TL_STRUCT_ROW(tl_fault) TL_FAULT_FIELDS(TL_FIELD_ROW, TL_ARRAY_ROW)
#undef TL_STRUCT
#define TL_STRUCT tl_part
    TL_STRUCT_ROW(tl_part) TL_PART_FIELDS(TL_FIELD_ROW, TL_ARRAY_ROW)
#undef TL_STRUCT
#define TL_STRUCT tl_read
    TL_STRUCT_ROW(tl_read) TL_READ_FIELDS(TL_FIELD_ROW, TL_ARRAY_ROW)
#undef TL_STRUCT
#define TL_STRUCT tl_clocks
    TL_STRUCT_ROW(tl_clocks) TL_CLOCKS_FIELDS(TL_FIELD_ROW, TL_ARRAY_ROW)
#undef TL_STRUCT
#define TL_STRUCT tl_link
    TL_STRUCT_ROW(tl_link) TL_LINK_FIELDS(TL_FIELD_ROW, TL_ARRAY_ROW)
#undef TL_STRUCT
#define TL_STRUCT tl_instance
    TL_STRUCT_ROW(tl_instance) TL_INSTANCE_FIELDS(TL_FIELD_ROW, TL_ARRAY_ROW)
#undef TL_STRUCT
#define TL_STRUCT tl_plan
    TL_STRUCT_ROW(tl_plan) TL_PLAN_FIELDS(TL_FIELD_ROW, TL_ARRAY_ROW)
#undef TL_STRUCT
};

TL_EXPORT int tl_layout(int i, const char **structure, const char **field, const char **type, int64_t *offset, int64_t *size) {
    if (i < 0 || (size_t)i >= sizeof ROWS / sizeof ROWS[0]) return 0;
    *structure = ROWS[i].structure, *field = ROWS[i].field, *type = ROWS[i].type;
    *offset = ROWS[i].offset, *size = ROWS[i].size;
    return 1;
}
