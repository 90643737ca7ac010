/*
 * io.h -- internal helpers shared by the file formats of src/io/.
 *
 * Every writer writes through pa__out_open / pa__out_commit / pa__out_abort
 * (output.c): a temporary "<path>.tmp.<pid>" renamed onto path only after a
 * complete, successful write and, inside an output transaction
 * (pa_output_begin), only when every file of the transaction is complete; so
 * a failure never leaves a partial or truncated file, nor some outputs of a
 * command without the others. Readers report errors as "FILE:LINE: message"
 * (binary files: byte offset).
 */
#ifndef PA_IO_H
#define PA_IO_H

#include "mesh/mesh.h"

#include <stdio.h>

/* A file being written. Zero-initialised, pa__out_abort does nothing. */
typedef struct pa__outfile {
  FILE *fp;
  char *path;    /* final path */
  char *tmppath; /* temporary path written first */
  int slot;      /* its place in the list the signal handler reads */
  int joined;    /* 1: part of an open transaction, renamed at its commit */
} pa__outfile;

/* Open a temporary file beside path for writing ("wb"). Refuses a path that
 * exists and is not a regular file, and a path already written in the open
 * transaction. */
pa_status pa__out_open(pa__outfile *out, const char *path);
/* Flush, fsync and close, checking every write error; then rename onto the
 * final path, or, inside a transaction, leave it for pa_output_commit. */
pa_status pa__out_commit(pa__outfile *out);
/* Close and remove the temporary file; inside a transaction, mark it failed
 * (safe to call after commit or twice). */
void pa__out_abort(pa__outfile *out);
/* Open for update ("r+b") the temporary of path, completed earlier in the
 * open transaction; end it with pa__out_commit or pa__out_abort again. */
pa_status pa__out_reopen(pa__outfile *out, const char *path);
/* Remove path (a regular file, or nothing) when the open transaction
 * commits. */
pa_status pa__out_remove(const char *path);
/* The temporary of path, completed in the open transaction, or NULL. */
const char *pa__out_tmppath(const char *path);
/* Open begins of the calling thread's output transaction (0: none). */
int pa__output_depth(void);

/* FNV-1a 64 of n bytes, continuing from h (start with PA_IO_FNV1A64_INIT). */
#define PA_IO_FNV1A64_INIT 0xcbf29ce484222325ull
static inline uint64_t pa__fnv1a64(uint64_t h, const void *p, size_t n) {
  const unsigned char *b = p;
  for (size_t i = 0; i < n; i++) {
    h ^= b[i];
    h *= 0x100000001b3ull;
  }
  return h;
}
/* Size and FNV-1a 64 of the bytes of a file. */
pa_status pa__file_fnv1a64(const char *path, int64_t *bytes, uint64_t *hash);

/* Lower-case extension of path including the dot (".mesh"), "" if none. */
const char *pa__path_ext(const char *path, char *buf, size_t len);

/* x in the form of printf's "%.*g" with precision prec into s (room for 32
 * chars), the same bytes as snprintf; its length. fmt.c. */
int pa__fmt_g(char *s, double x, int prec);
/* The shorter of x's "%.15g" and "%.17g" forms that reads back exactly
 * (strtod) into s (room for 32 chars); its length. fmt.c. */
int pa__fmt_shortest(char *s, double x);
/* v in decimal ("%lld") into s (room for 21 chars, not terminated); its
 * length. fmt.c. */
int pa__fmt_int(char *s, int64_t v);

/* Format readers/writers, dispatched by pa_mesh_read/pa_mesh_write. */
pa_status pa__medit_read(const char *path, pa_mesh **mesh);
pa_status pa__medit_write(pa_mesh *mesh, const char *path, int binary,
                          int version);
pa_status pa__gmsh_read(const char *path, pa_mesh **mesh);
/* MSH 4.1 with its classification (pa_mesh_read_model). */
pa_status pa__gmsh_read_model(const char *path, pa_mesh **mesh);
pa_status pa__gmsh_write(pa_mesh *mesh, const char *path, int binary);

/* The arrays a distributed set's rank file adds (src/dmesh/dio.c); NULL
 * members are not written. */
typedef struct pa__vtu_extra {
  int rank;              /* cell data "rank" of every cell */
  const int64_t *vgid;   /* point data "gid", the points' GlobalIds */
  const uint8_t *vghost; /* point data "vtkGhostType": 1 (a duplicate) on
                            the vertices another rank owns */
  const int64_t *cgid;   /* cell data "gid": each cell's global id among
                            the entities of its kind (elements, boundary
                            entities, edges: the "entity" array) */
} pa__vtu_extra;
pa_status pa__vtu_write(pa_mesh *mesh, const char *path, int diagnostics,
                        const pa__vtu_extra *extra);

/* ---- Medit keyword files (libMeshb layout), shared by medit.c and sol.c ----
 * Defined in medit.c; the layout and the reader's invariants are described at
 * the top of that file. */

/* libMeshb keyword codes used by padapt. libMeshb 7 has no code for
 * RequiredTetrahedra (12 is "reserved" there); Mmg writes it as 12. */
enum {
  PA_IO_GMF_DIMENSION = 3,
  PA_IO_GMF_VERTICES = 4,
  PA_IO_GMF_EDGES = 5,
  PA_IO_GMF_TRIANGLES = 6,
  PA_IO_GMF_QUADRILATERALS = 7,
  PA_IO_GMF_TETRAHEDRA = 8,
  PA_IO_GMF_PRISMS = 9,
  PA_IO_GMF_HEXAHEDRA = 10,
  PA_IO_GMF_REQUIRED_TETRAHEDRA = 12,
  PA_IO_GMF_CORNERS = 13,
  PA_IO_GMF_RIDGES = 14,
  PA_IO_GMF_REQUIRED_VERTICES = 15,
  PA_IO_GMF_REQUIRED_EDGES = 16,
  PA_IO_GMF_REQUIRED_TRIANGLES = 17,
  PA_IO_GMF_PYRAMIDS = 49,
  PA_IO_GMF_END = 54,
  PA_IO_GMF_SOL_AT_VERTICES = 62
};
/* Most solution types in one SolAtVertices keyword (libMeshb's GmfMaxTyp). */
#define PA_IO_GMF_MAX_TYPES 1000

/* A keyword file open for reading (ASCII or binary). */
typedef struct pa__gmf pa__gmf;

/* Open path; binary selects the .meshb/.solb layout. Reads the binary header.
 * path must stay valid until pa__gmf_close. */
pa_status pa__gmf_open(const char *path, int binary, pa__gmf **gmf);
void pa__gmf_close(pa__gmf *gmf); /* NULL allowed */
/* Dimension read so far (0 if none yet). */
int pa__gmf_dim(const pa__gmf *gmf);
/* Next data keyword: its code, PA_IO_GMF_END at End or at the end of an ASCII
 * file. MeshVersionFormatted and Dimension are consumed here. An unknown
 * ASCII keyword is an error; unknown binary codes are returned (skip them). */
pa_status pa__gmf_next(pa__gmf *gmf, int *code);
/* Skip the data of the current keyword. */
pa_status pa__gmf_skip(pa__gmf *gmf);
/* After reading a keyword's data: move to the next keyword. */
pa_status pa__gmf_done(pa__gmf *gmf);
/* Read the record count of the current keyword and check that n records of
 * nreal reals and nint integers fit in what is left of the file. Fails if no
 * Dimension was read yet. */
pa_status pa__gmf_count(pa__gmf *gmf, int nreal, int nint, pa_idx *n);
/* Check that n records of nreal reals and nint integers fit in the file. */
pa_status pa__gmf_check_room(pa__gmf *gmf, pa_idx n, int nreal, int nint);
/* Read one 32-bit header word (e.g. the solution types of SolAtVertices). */
pa_status pa__gmf_word(pa__gmf *gmf, int *value);
/* Records per pa__gmf_records call that keep its buffers near 4 MiB. */
size_t pa__gmf_chunk(int nreal, int nint);
/* Read n records of nreal reals then nint integers. *rv and *iv (either may
 * be NULL) point to internal buffers valid until the next call. */
pa_status pa__gmf_records(pa__gmf *gmf, size_t n, int nreal, int nint,
                          const double **rv, const int64_t **iv);
/* Locations for messages: line (ASCII) or byte offset (binary) of the last
 * token read, of record k of the last pa__gmf_records call, of the current
 * keyword. */
int64_t pa__gmf_loc(const pa__gmf *gmf);
int64_t pa__gmf_rec_loc(const pa__gmf *gmf, size_t k);
int64_t pa__gmf_kwd_loc(const pa__gmf *gmf);
/* "PATH:LINE" (ASCII) or "PATH: byte OFFSET" (binary) of a location, as
 * the messages name it. */
void pa__gmf_where(const pa__gmf *gmf, int64_t loc, char *buf, size_t n);
/* Raise "FILE:LINE: msg" (ASCII) or "FILE: byte OFFSET: msg" (binary). */
pa_status pa__gmf_error(const pa__gmf *gmf, int64_t loc, pa_status code,
                        const char *fmt, ...)
    __attribute__((format(printf, 4, 5)));
/* Name of a keyword code ("Vertices"), "?" if unknown. */
const char *pa__gmf_kwd_name(int code);

/* Raise a format error at loc and jump to cleanup (needs `pa_status st`). */
#define PA_IO_GMF_FAIL(gmf, loc, ...)                                        \
  do {                                                                       \
    st = pa__gmf_error((gmf), (loc), PA_ERR_FORMAT, __VA_ARGS__);            \
    goto cleanup;                                                            \
  } while (0)

/* A keyword file being written, through pa__out_open. */
typedef struct pa__gmfw pa__gmfw;

/* Open and write the header; version 1-4 (binary; ASCII always writes 2). */
pa_status pa__gmfw_open(const char *path, int binary, int version, int dim,
                        pa__gmfw **gmfw);
/* Start keyword code with n records of nreal reals and nint integers; for a
 * solution keyword, ntype > 0 types follow the count. */
pa_status pa__gmfw_kwd(pa__gmfw *gmfw, int code, pa_idx n, int nreal, int nint,
                       int ntype, const int *type);
/* Write one record (the nreal reals and nint integers of the keyword). */
pa_status pa__gmfw_rec(pa__gmfw *gmfw, const double *rv, const int64_t *iv);
/* Write End and commit the file; frees gmfw, also on failure. */
pa_status pa__gmfw_close(pa__gmfw *gmfw);
/* Drop the file being written and free gmfw (NULL allowed). */
void pa__gmfw_abort(pa__gmfw *gmfw);
/* Binary version to write by default for a payload of about `bytes`: 2, or 3
 * when 32-bit positions cannot address the file. */
int pa__gmf_default_version(int64_t bytes);

#endif /* PA_IO_H */
