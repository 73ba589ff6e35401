// Errors as values: every stage that can fail on user data returns a Status
// instead of aborting, so that the command and the GUI can report one clear
// line (see ../shared/STYLE.md, "Errors are values at the edges").
#pragma once

#include <functional>
#include <string>
#include <utility>

namespace glomap {

class Status {
 public:
  static Status Ok() { return Status(); }
  // The run was stopped by the user (GUI cancel); not an error in the data.
  static Status Cancelled() {
    Status status = Error("Stopped by the user.");
    status.cancelled_ = true;
    return status;
  }
  static Status Error(std::string message) {
    Status status;
    status.ok_ = false;
    status.message_ = std::move(message);
    return status;
  }

  bool ok() const { return ok_; }
  bool cancelled() const { return cancelled_; }
  const std::string& message() const { return message_; }

 private:
  bool ok_ = true;
  bool cancelled_ = false;
  std::string message_;
};

// Lets a long stage stop promptly when the user cancels: stages poll
// IsStopped() between steps and from Ceres iteration callbacks, and return
// Status::Cancelled().
struct Interrupt {
  std::function<bool()> is_stopped;

  bool IsStopped() const { return is_stopped && is_stopped(); }
};

}  // namespace glomap
