#ifndef AQS_CONTACT_READ_OBSTACLES_H_
#define AQS_CONTACT_READ_OBSTACLES_H_

#include <ostream>
#include <string>
#include <vector>

#include "contact/obstacle.h"
#include "model/active_model.h"

namespace aqs {

// The rigid obstacles of a spec text (ParseObstacleSpecs syntax: "path [vertices=a:b]
// [bone=name]" items separated by commas) for `model`, ready for ContactSolver::Resolve:
// each file read (ReadObstacleSurfaces), checked to lie near the model
// (CheckPointsNearModel), tied to the model's bone of its name (-1: fixed), and split
// into one obstacle per closed shell (SplitIntoShells: a file of teeth holds one shell
// per tooth). Appends them to *obstacles and logs one line per file. False with *error
// naming the item or file: a bad spec, an unreadable file, a surface far from the model,
// a bone the model does not have.
bool ReadMovingObstacles(const std::string& spec, const ActiveModel& model,
                         std::vector<MovingObstacle>* obstacles, std::ostream& log,
                         std::string* error);

}  // namespace aqs

#endif  // AQS_CONTACT_READ_OBSTACLES_H_
