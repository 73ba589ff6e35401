// "Reconstruction > Global reconstruction options...": every GlobalMapper.*
// option, one page per pipeline stage, built from GlobalMapperOptionTable so
// that names, defaults and help texts are always those of the command line.
#pragma once

#include <QtWidgets>
#include <functional>
#include <string>
#include <vector>

#include "colmap_ext/global_mapper_options.h"
#include "glomap/controllers/global_mapper.h"

namespace colmap {

class GlobalMapperOptionsDialog : public QDialog {
 public:
  // Edits `*options` (kept by pointer); `on_accepted` runs after OK has
  // written valid values into it.
  GlobalMapperOptionsDialog(QWidget* parent,
                            glomap::GlobalMapperOptions* options,
                            std::function<void()> on_accepted);

  // Number of option rows (one per table entry), for tests.
  int NumOptions() const { return static_cast<int>(rows_.size()); }
  // The stage groups, in pipeline order.
  QStringList Groups() const;

  // Copies the editor values into the options if they are valid; else shows
  // why not and returns false.
  bool Apply();

 protected:
  void showEvent(QShowEvent* event) override;

 private:
  struct Row {
    glomap::GlobalMapperOptionEntry entry;
    QWidget* editor;
  };

  // Fills the editors from `edited_`.
  void ReadValues();
  // Writes the editors into `edited_`; returns the keys that do not parse.
  std::vector<std::string> WriteValues();

  glomap::GlobalMapperOptions* options_;
  std::function<void()> on_accepted_;
  // The values being edited; the table's pointers point into it, so it is
  // assigned to, never replaced.
  glomap::GlobalMapperOptions edited_;
  std::vector<Row> rows_;
  QListWidget* group_list_;
};

}  // namespace colmap
