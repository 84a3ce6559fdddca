// aqs_fit: fit a trained model's latent (and bone motions) to a new pose, markers or a
// scan, and write the fitted surface (the neutral's vertex order and faces); or, with
// --sequence, to an ordered sequence of them, frame after frame (resumable). Under
// mpirun (or with --mpi) the frames of a sequence fitted with
// --sequence_warm_start=false are shared among the ranks (docs/distributed.md).
// Exit status: 0 done; 1 bad input, or MPI wanted but not built; 2 the fit failed (no
// start, or a solve failed; finite results are still written, for inspection) or, for
// a sequence, a frame's fit did (the frames before it are written).

#include <iostream>

#include <gflags/gflags.h>

#include "app_common.h"
#include "fit_flags.h"
#include "jobs/fit_job.h"
#include "jobs/fit_sequence.h"
#include "mpi_flags.h"
#include "util/vertex_ranges.h"

DECLARE_string(model);
DEFINE_string(target, "", "The target: a pose surface (OBJ, the neutral's vertex order), a "
              "markers file ('vertex x y z' lines, .txt) or a point cloud (OBJ or PLY).");
DEFINE_string(sequence, "", "Instead of --target: an ordered sequence of targets of one kind, "
              "fitted frame after frame: a folder (its .obj/.txt/.ply files by name), a glob, a "
              ".txt list (one file per line) or a comma list. Needs --output_dir.");
DEFINE_string(output_dir, "", "Sequences: the folder of the outputs (<frame>.obj, frames.csv, "
              "latents.bin); a rerun resumes at the first frame not done.");
DEFINE_bool(sequence_warm_start, true, "Sequences: start each frame from the previous frame's "
            "result (true), or fit every frame on its own from the start chosen for it (false: "
            "a frame's result depends only on its target, and under mpirun the frames are "
            "shared among the ranks, with the outputs of one process).");
DEFINE_string(target_kind, "auto", "pose, markers, points or auto (by extension and vertex count).");
DEFINE_string(landmarks, "", "Optional, with a point-cloud target: landmarks of the scan, points "
              "whose vertex is known (e.g. eye and mouth corners; a markers file, 'vertex x y z' "
              "lines), fitted with it (--landmark_weight). With a --sequence of scans: one such "
              "file per frame, listed as --sequence is (folder, glob, .txt list or comma list), "
              "in the frames' order.");
DEFINE_string(output, "", "The fitted surface (OBJ).");
DEFINE_string(output_volume, "", "Optional: the fitted equilibrium (.vtu for ParaView, or .mesh).");
DEFINE_string(output_uncertainty, "", "Optional: the fitted surface with each vertex's standard "
              "deviation (PLY with a scalar and viridis colours): how well the data determine "
              "it, from the covariance of the fitted latent and bones.");
DEFINE_string(latent_output, "", "Optional: the fitted latent (and bones) as a latent file.");
DEFINE_string(initial_latent, "", "Optional: start from this latent file (default: the centre of "
              "the model's latent prior, bones at rest).");
DEFINE_string(compare_to, "", "Optional: a ground-truth surface (OBJ, the neutral's vertex order) "
              "to measure the fitted surface against (e.g. the pose a scan was taken of).");
DEFINE_string(compare_vertices, "", "Vertices of that comparison, e.g. 0:9409 (default: all).");

int main(int argc, char** argv) {
  aqs::InitApp("Fit a trained model to a pose, markers or a scan, or to a sequence of them.\n"
               "  aqs_fit --model=MODEL --target=T --output=OUT.obj [--latent_output=Z.txt]\n"
               "  aqs_fit --model=MODEL --sequence=DIR|GLOB|LIST.txt --output_dir=OUT\n"
               "  mpirun -np N aqs_fit --sequence=... --sequence_warm_start=false ...\n"
               "      (independent frames shared among N ranks; rank 0 writes the outputs)",
               &argc, &argv);
  const std::unique_ptr<aqs::Communicator> ranks = aqs::StartRanks(&argc, &argv);
  const bool distributed = ranks != nullptr && ranks->size() > 1;
  std::string error;
  aqs::LatentFitOptions fit;
  aqs::PointCloudFitOptions points;
  aqs::FitStartOptions start;
  if (!aqs::FitOptionsFromFlags(&fit, &points, &start, &error)) {
    aqs::PrintRankError(ranks.get(), error);
    return 1;
  }
  if (!FLAGS_sequence.empty()) {
    if (!FLAGS_target.empty() || !FLAGS_output.empty()) {
      aqs::PrintRankError(ranks.get(),
                          "--sequence goes with --output_dir, not with --target or --output");
      return 1;
    }
    // The single target's flags would be dropped without a word.
    for (const auto& [flag, value] :
         {std::pair<const char*, const std::string*>{"--initial_latent", &FLAGS_initial_latent},
          {"--latent_output", &FLAGS_latent_output},
          {"--output_volume", &FLAGS_output_volume},
          {"--output_uncertainty", &FLAGS_output_uncertainty},
          {"--compare_to", &FLAGS_compare_to},
          {"--compare_vertices", &FLAGS_compare_vertices}}) {
      if (!value->empty()) {
        aqs::PrintRankError(ranks.get(), std::string(flag) + " applies to one --target, not to "
                                         "a --sequence (which writes frames.csv, latents.bin "
                                         "and one OBJ per frame)");
        return 1;
      }
    }
    aqs::FitSequenceOptions options;
    options.model = FLAGS_model;
    options.sequence = FLAGS_sequence;
    options.target_kind = FLAGS_target_kind;
    options.landmarks = FLAGS_landmarks;
    options.output_dir = FLAGS_output_dir;
    options.fit = fit;
    options.points = points;
    options.start = start;
    options.warm_start = FLAGS_sequence_warm_start;
    options.temporal_prior = aqs::TemporalPriorFlag();
    options.communicator = ranks.get();
    const aqs::FitSequenceResult result = aqs::RunFitSequenceJob(options, std::cout);
    if (result.status != aqs::JobStatus::kOk) {
      aqs::PrintRankError(ranks.get(), aqs::FlagError(result.message, aqs::FitFlagNames()));
    }
    return aqs::ExitStatus(result.status);
  }
  if (aqs::TemporalPriorFlag() != 0.0) {
    aqs::PrintRankError(ranks.get(), "--temporal_prior pulls a sequence's frame toward the one "
                                     "before it: it applies to a --sequence, not to one --target");
    return 1;
  }
  // A sequence's flags, and a comparison's vertices without the comparison, would be
  // dropped without a word.
  if (!FLAGS_output_dir.empty() ||
      !gflags::GetCommandLineFlagInfoOrDie("sequence_warm_start").is_default) {
    aqs::PrintRankError(ranks.get(), std::string(FLAGS_output_dir.empty()
                                                     ? "--sequence_warm_start"
                                                     : "--output_dir") +
                                         " applies to a --sequence, not to one --target "
                                         "(whose outputs are --output and its kin)");
    return 1;
  }
  if (!FLAGS_compare_vertices.empty() && FLAGS_compare_to.empty()) {
    aqs::PrintRankError(ranks.get(), "--compare_vertices chooses the vertices of the comparison "
                                     "with --compare_to, which is not given");
    return 1;
  }
  if (distributed) {
    aqs::PrintRankError(ranks.get(), "one --target is fitted by one process, not by " +
                                         std::to_string(ranks->size()) +
                                         " ranks: run aqs_fit without mpirun, or share the "
                                         "frames of a --sequence with --sequence_warm_start=false");
    return 1;
  }
  aqs::FitJobOptions options;
  options.model = FLAGS_model;
  options.target = FLAGS_target;
  options.target_kind = FLAGS_target_kind;
  options.landmarks = FLAGS_landmarks;
  options.output = FLAGS_output;
  options.output_volume = FLAGS_output_volume;
  options.latent_output = FLAGS_latent_output;
  options.output_uncertainty = FLAGS_output_uncertainty;
  options.initial_latent = FLAGS_initial_latent;
  options.compare_to = FLAGS_compare_to;
  if (!FLAGS_compare_vertices.empty() &&
      !aqs::ParseVertexRanges(FLAGS_compare_vertices, &options.compare_vertices, &error)) {
    aqs::PrintError("--compare_vertices: " + error);
    return 1;
  }
  options.fit = fit;
  options.points = points;
  options.start = start;
  const aqs::FitJobResult result = aqs::RunFitJob(options, std::cout);
  return aqs::FinishJob(result.status, result.message, aqs::FitFlagNames());
}
