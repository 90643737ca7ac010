/*
 * bisect_remesher.h -- a second remesher for padapt, written against the
 * public plug-in interface only (padapt.h): longest-edge bisection.
 */
#ifndef BISECT_REMESHER_H
#define BISECT_REMESHER_H

#include "padapt.h"

/**
 * A remesher (2D and 3D) that splits, conformingly and longest first, every
 * edge longer than sqrt(2) in the metric that belongs to no frozen element
 * (PA_FLAG_REQUIRED element, boundary entity or feature edge). It never
 * moves nor removes anything, so it cannot coarsen: edges shorter than
 * 0.7071 make the outcome PA_REMESH_TARGET_MISSED. Midpoints get the
 * average of the end fields (exact for linear fields) and the geometric
 * mean of the sizes (arithmetic mean of tensors).
 */
const pa_remesher *bisect_remesher(void);

#endif
