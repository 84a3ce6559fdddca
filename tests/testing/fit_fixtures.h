#ifndef AQS_TESTING_FIT_FIXTURES_H_
#define AQS_TESTING_FIT_FIXTURES_H_

#include "model/active_model.h"

namespace aqs {
namespace testing {

// A small pre-trained model of the synthetic-muscle bar (8 poses, latent 3, tanh
// decoder 16-16; no end-to-end training), for fits. with_bone: its fixed end is a bone
// "base" (rest in every training pose) instead of static vertices. with_free_piece: the
// mesh also has one element apart from the bar, above it, that nothing holds and no
// surface vertex is embedded in (as meshers leave; prepare kept such pieces): its
// exact stiffness is singular at every state.
ActiveModel PretrainedBarForFits(bool with_bone, bool with_free_piece = false);

// Sets model->states to every training pose's equilibrium (its latent, bones as in the
// pose), as training stores them: what LatentFitter::ChooseStart starts from. False if
// one cannot be simulated.
bool StoreTrainingEquilibria(ActiveModel* model);

}  // namespace testing
}  // namespace aqs

#endif  // AQS_TESTING_FIT_FIXTURES_H_
