// Everything a user needs: tensors, the tape, gradcheck and all ops.
#pragma once

#include "autodiff/gradcheck.h"
#include "autodiff/parallel.h"
#include "autodiff/tape.h"
#include "autodiff/tensor.h"
#include "ops/antialias.h"
#include "ops/elementwise.h"
#include "ops/fragments.h"
#include "ops/interpolate.h"
#include "ops/linalg.h"
#include "ops/project.h"
#include "ops/rasterize.h"
#include "ops/reduce.h"
#include "ops/shape_ops.h"
#include "ops/texture.h"
#include "ops/transforms.h"
#include "ops/vector.h"
