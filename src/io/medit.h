/*
 * medit.h -- Medit meshes (.mesh, .meshb) and the keyword files under them
 * and under the solutions of sol.c (medit.c).
 */
#ifndef PA_IO_MEDIT_H
#define PA_IO_MEDIT_H

#include "mesh/mesh.h"

#include <stdint.h>

pa_status pa__medit_read(const char *path, pa_mesh **mesh);
pa_status pa__medit_write(pa_mesh *mesh, const char *path, int binary,
                          int version);

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
  PA_IO_GMF_SOL_AT_VERTICES = 62,
  PA_IO_GMF_SOL_AT_EDGES = 63,
  PA_IO_GMF_SOL_AT_TRIANGLES = 64,
  PA_IO_GMF_SOL_AT_TETRAHEDRA = 66
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
 * ASCII keyword is skipped with its data (the numbers and quoted strings up
 * to the next word); unknown binary codes are returned (skip them). At the
 * end, a note at verbosity 1 names the keywords skipped. */
pa_status pa__gmf_next(pa__gmf *gmf, int *code);
/* Skip the data of the current keyword. */
pa_status pa__gmf_skip(pa__gmf *gmf);
/* The keywords skipped so far, for messages ("Identifier, SubDomainFromMesh";
 * "" if none); *unknown (if not NULL) is the location of the first one that
 * is not in the keyword table of medit.c (an unknown ASCII name or binary
 * code), -1 if none. */
const char *pa__gmf_skipped(const pa__gmf *gmf, int64_t *unknown);
/* For the keyword of an element kind padapt does not support (quadrilaterals,
 * prisms, hexahedra, pyramids, high-order elements): the integers of one of
 * its records (vertices and reference); 0 for any other keyword. */
int pa__gmf_unsupported_cell(int code);
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

#endif /* PA_IO_MEDIT_H */
