// aqs_collide: a trained model's pose re-solved with contact: its surface kept out of
// rigid obstacles (e.g. teeth moving with the jaw) and out of itself (lips, eyelids),
// with a report of penetrations and intersecting triangles before and after.
// Exit status: 0 done; 1 bad input; 2 the contact equilibrium was not reached.

#include <iostream>

#include <gflags/gflags.h>

#include "app_common.h"
#include "jobs/collide_job.h"
#include "util/vertex_ranges.h"

DECLARE_string(model);
DECLARE_int32(threads);
DEFINE_string(latent, "", "A latent file (as aqs_fit writes) to pose the model with.");
DEFINE_string(pose, "", "Or a training pose's name.");
DEFINE_string(obstacles, "", "Rigid obstacles: 'path [vertices=a:b] [bone=name]' items "
              "separated by commas (e.g. the lower teeth moving with the jaw bone); a path "
              "with spaces or commas goes in double quotes.");
DEFINE_string(output, "", "The surface with contact (OBJ).");
DEFINE_string(output_before, "", "Optional: the surface without contact (OBJ).");
DEFINE_string(output_volume, "", "Optional: the equilibrium with contact (.vtu or .mesh).");
DEFINE_string(output_intersections, "", "Optional: PLY of the surface with contact, coloured by "
              "the self-intersecting triangle pairs (new since rest) each vertex is part of.");
DEFINE_string(report, "", "Optional: the contact report as a text file.");
DEFINE_double(thickness, 0.05, "Contact thickness (model units).");
DEFINE_double(contact_stiffness, 1000.0, "Penalty stiffness per unit area, relative to one "
              "layer of elements.");
DEFINE_bool(self_contact, true, "Also keep the surface out of itself.");
DEFINE_bool(edge_contact, true,
            "Self contact: also edge-edge pairs (crossings no vertex passes through).");
DEFINE_double(search_radius, 0.5, "Candidate search radius (model units).");
DEFINE_int32(exclusion_rings, 3, "Self contact: a point never pairs with triangles within this "
             "many edge rings.");
DEFINE_double(max_depth, 1.0, "Self contact: a point pairs with a triangle while it is less than "
              "this far behind it (model units).");
DEFINE_int32(contact_rounds, 6, "Detection and solve rounds (per path step).");
DEFINE_int32(path_steps, 8, "Follow the contact equilibrium from rest to the pose in this many "
             "steps of actuation and bone motion (halved where a step adds intersections); "
             "0: start from the contact-free pose (enough for shallow penetrations).");
DEFINE_double(contact_tolerance, 1e-5, "Relative force tolerance of the contact equilibria.");
DEFINE_string(contact_vertices, "", "Surface vertices taking part in contact, e.g. 0:11248 "
              "(default: all).");

int main(int argc, char** argv) {
  aqs::InitApp("Resolve contacts of a trained model's pose.\n"
               "  aqs_collide --model=MODEL (--latent=Z.txt | --pose=NAME) "
               "--obstacles='teeth.obj vertices=0:2208, teeth.obj vertices=2208:4412 bone=jaw' "
               "--output=OUT.obj",
               &argc, &argv);
  aqs::CollideJobOptions options;
  options.model = FLAGS_model;
  options.latent = FLAGS_latent;
  options.pose = FLAGS_pose;
  options.obstacles = FLAGS_obstacles;
  options.output = FLAGS_output;
  options.output_before = FLAGS_output_before;
  options.output_volume = FLAGS_output_volume;
  options.report = FLAGS_report;
  options.output_intersections = FLAGS_output_intersections;
  options.contact.thickness = FLAGS_thickness;
  options.contact.relative_stiffness = FLAGS_contact_stiffness;
  options.contact.self_contact = FLAGS_self_contact;
  options.contact.edge_contact = FLAGS_edge_contact;
  options.contact.search_radius = FLAGS_search_radius;
  options.contact.exclusion_rings = FLAGS_exclusion_rings;
  options.contact.max_rounds = FLAGS_contact_rounds;
  options.contact.path_steps = FLAGS_path_steps;
  options.contact.max_depth = FLAGS_max_depth;
  options.contact.solver.relative_force_tolerance = FLAGS_contact_tolerance;
  options.contact.num_threads = FLAGS_threads;
  std::string error;
  if (!aqs::SolverMethodFromFlag(&options.contact.solver, &error)) {
    aqs::PrintError(error);
    return 1;
  }
  if (!FLAGS_contact_vertices.empty() &&
      !aqs::ParseVertexRanges(FLAGS_contact_vertices, &options.contact.surface_vertices, &error)) {
    aqs::PrintError("--contact_vertices: " + error);
    return 1;
  }
  aqs::FlagNames flags = aqs::CommonFlagNames("contact.");
  flags.insert(flags.end(),
               {{"contact.thickness", "--thickness"},
                {"contact.relative_stiffness", "--contact_stiffness"},
                {"contact.search_radius", "--search_radius"},
                {"contact.exclusion_rings", "--exclusion_rings"},
                {"contact.max_depth", "--max_depth"},
                {"contact.max_rounds", "--contact_rounds"},
                {"contact.path_steps", "--path_steps"},
                {"contact.solver.relative_force_tolerance", "--contact_tolerance"}});
  const aqs::CollideJobResult result = aqs::RunCollideJob(options, std::cout);
  return aqs::FinishJob(result.status, result.message, flags);
}
