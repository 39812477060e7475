/* Blue noise that follows a density (dpc_generate_density; docs/density.md states the
 * definition): a 2-D cascade run with every distance measured in units of the local spacing.
 *
 * The density is piecewise constant over a W x H grid of cells on [0,1)^2 (cell (cx, cy) is
 * [cx/W, (cx+1)/W) x [cy/H, (cy+1)/H), value density[cy * W + cx]). The input points are the
 * model's input kind mapped through the density's inverse CDF (rows, then the cell within the
 * row), so they follow it exactly and keep their strata. Each layer then moves point i by
 *     sum_j h_ij g(d_ij / (rho h_ij)) delta_ij / d_ij,   h = (m rho(x))^(-1/2),
 *     h_ij = 2 h_i h_j / (h_i + h_j) (the harmonic mean: the pair's two terms are equal and
 *     opposite, and a sparse point does not push back the dense side of an edge), or
 *     h_ij = min(h_i, h_j) where the two differ more than 2 times,
 * with glide-mirror edges: across a side of the square a point sees the set mirrored and shifted
 * along that side by GLIDE mean spacings (at most 1/4) towards the side's middle from the point's
 * half, where the shifted coordinate stays in [0, 1); at a corner, mirrored across both sides
 * (density.c, "GLIDE"). No pair farther apart than half the square interacts, and h is at most
 * 1. Walls (walls.h: cell boundaries where the density changes more than 4 times, or to zero) are
 * mirrors too: a point within 2 h of one of its own also sees the mirror images, across the wall's
 * line at its nearest point, of itself and of its pairs of its own spacing on its side; where that
 * point lies along a segment that runs on for WALL_GLIDE h towards the square's middle, a glide
 * mirror: the images of its side's points shifted that far along the line (density.c,
 * "WALL_GLIDE"). A step that would leave the square is mirrored back; one that
 * would end in a cell whose density differs more than 4 times from its start (a zero cell among
 * them) is not taken. Everything is float32 in one fixed order (double for the inverse CDF), the
 * same bits for every CPU and thread count. */
#ifndef DPC_DENSITY_DENSITY_H
#define DPC_DENSITY_DENSITY_H

#include <stddef.h>
#include <stdint.h>

#include "model/model_handle.h"

/* Check the model and the density (finite, >= 0, positive somewhere, shape within bounds) as
 * dpc_generate_density does, before any work; DPC_OK or a status with its message. */
dpc_status dpc_density_check(const dpc_model *model, const float *density, uint32_t width, uint32_t height);

/* m points (checked) following density into out (m * 2 floats); threads from the model's engine. */
dpc_status dpc_density_generate(const dpc_model *model, const float *density, uint32_t width, uint32_t height,
                                uint64_t seed, size_t m, float *out);

#endif
