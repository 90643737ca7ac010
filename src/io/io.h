/*
 * io.h -- the file formats of src/io/, for the components above it: one
 * header per file of the component (output.h the output files and
 * transactions, fmt.h numbers as text, medit.h Medit meshes and keyword
 * files, gmsh.h, vtu.h), gathered here. The files of src/io/ include the
 * headers they need, never this one: io.c, the dispatch of pa_mesh_read and
 * pa_mesh_write by extension, calls them, and nothing calls back.
 *
 * Readers report errors as "FILE:LINE: message" (binary files: byte
 * offset); every writer writes through the output files of output.h.
 */
#ifndef PA_IO_H
#define PA_IO_H

#include "io/fmt.h"
#include "io/gmsh.h"
#include "io/medit.h"
#include "io/output.h"
#include "io/vtu.h"

#endif /* PA_IO_H */
