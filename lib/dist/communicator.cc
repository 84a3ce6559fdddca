#include "dist/communicator.h"

#include <algorithm>
#include <cstring>

namespace aqs {

void Communicator::BroadcastText(std::string* text, int root) const {
  int length = static_cast<int>(text->size());
  Broadcast(&length, 1, root);
  // Sent as doubles of 8 characters each (the collectives move numbers).
  std::vector<double> packed((length + 7) / 8, 0.0);
  if (rank() == root) std::memcpy(packed.data(), text->data(), text->size());
  Broadcast(packed.data(), static_cast<int>(packed.size()), root);
  if (rank() != root) text->assign(reinterpret_cast<const char*>(packed.data()), length);
}

bool Communicator::Agree(bool ok, std::string* error) const {
  int first_failing = ok ? size() : rank();
  MinToAll(&first_failing, 1);
  if (first_failing == size()) return true;
  std::string message = rank() == first_failing ? *error : std::string();
  BroadcastText(&message, first_failing);
  *error = (size() > 1 && first_failing > 0 ? "rank " + std::to_string(first_failing) + ": " : "") +
           message;
  return false;
}

void LocalCommunicator::GatherToRoot(const double* send, const std::vector<int>& counts,
                                     double* recv) const {
  if (!counts.empty() && counts[0] > 0) std::copy(send, send + counts[0], recv);
}

std::vector<int> OwnedIndices(int count, int rank, int size) {
  std::vector<int> owned;
  for (int p = rank; p < count; p += size) owned.push_back(p);
  return owned;
}

}  // namespace aqs
