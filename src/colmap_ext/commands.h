// Commands that this project adds to COLMAP's command table
// (src/colmap_ext/patches/0001-register-commands.patch).
#pragma once

namespace colmap {

// colmap automatic_reconstructor: COLMAP 3.8's command, unchanged, or with
// `--mapper global` its extraction and matching followed by the global mapper.
int RunAutomaticReconstructorWithMapperChoice(int argc, char** argv);

// colmap global_mapper: global Structure-from-Motion from a COLMAP database.
int RunGlobalMapper(int argc, char** argv);

// colmap model_evaluator: accuracy of a model against a ground-truth model.
int RunModelEvaluator(int argc, char** argv);

}  // namespace colmap
