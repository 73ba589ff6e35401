// Commands that this project adds to COLMAP's command table
// (src/colmap_ext/patches/0001-register-commands.patch).
#pragma once

namespace colmap {

// colmap global_mapper: global Structure-from-Motion from a COLMAP database.
int RunGlobalMapper(int argc, char** argv);

// colmap model_evaluator: accuracy of a model against a ground-truth model.
int RunModelEvaluator(int argc, char** argv);

}  // namespace colmap
