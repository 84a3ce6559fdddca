#include "dist/communicator.h"

#include <algorithm>
#include <cstring>
#include <vector>

namespace aqs {

void Communicator::BroadcastText(std::string* text, int root) const {
  // The length as a double (exact below 2^53: a text of any size a machine holds), then
  // the characters as doubles of 8 each (the collectives move numbers), in pieces of at
  // most kMaxPiece doubles (the collectives count in int).
  double length = static_cast<double>(text->size());
  Broadcast(&length, 1, root);
  const size_t bytes = static_cast<size_t>(length);
  std::vector<double> packed((bytes + 7) / 8, 0.0);
  // (memcpy of 0 bytes from an empty vector's null data() is undefined: UBSan aborted.)
  if (rank() == root && bytes > 0) std::memcpy(packed.data(), text->data(), bytes);
  constexpr size_t kMaxPiece = size_t{1} << 28;
  for (size_t begin = 0; begin < packed.size(); begin += kMaxPiece) {
    const size_t count = std::min(kMaxPiece, packed.size() - begin);
    Broadcast(packed.data() + begin, static_cast<int>(count), root);
  }
  if (rank() != root) text->assign(reinterpret_cast<const char*>(packed.data()), bytes);
}

int Communicator::FirstItemUnlikeRoot(const std::vector<std::string>& items,
                                      int* root_count) const {
  std::string text;
  for (const std::string& item : items) text += item + "\n";
  std::string root_text = text;
  BroadcastText(&root_text, 0);
  if (root_count != nullptr) {
    *root_count = static_cast<int>(std::count(root_text.begin(), root_text.end(), '\n'));
  }
  if (root_text == text) return -1;
  size_t at = 0, root_at = 0;
  for (int i = 0;; ++i) {
    const size_t end = text.find('\n', at), root_end = root_text.find('\n', root_at);
    if (end == std::string::npos || root_end == std::string::npos ||
        text.compare(at, end - at, root_text, root_at, root_end - root_at) != 0) {
      return i;
    }
    at = end + 1;
    root_at = root_end + 1;
  }
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
