// Mesh losses and reparametrizations (namespace gr): vertex normals,
// PyTorch3D's Laplacians and mesh losses, and the large-steps
// reparametrization. docs/mesh_losses.md.
#pragma once

#include "ops/mesh/large_steps.h"
#include "ops/mesh/laplacian.h"
#include "ops/mesh/losses.h"
#include "ops/mesh/vertex_normals.h"
