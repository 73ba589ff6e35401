// "Reconstruction > Global reconstruction options...": every GlobalMapper.*
// option, one page per pipeline stage, built from GlobalMapperOptionTable so
// that names, defaults and help texts are always those of the command line.
// It shows the basic options (those of `colmap global_mapper -h`); the
// "Advanced" toggle (off when the dialog is made) shows the others too.
// Hidden editors keep their values: OK applies every option either way.
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

  // Number of option rows (one per table entry, shown or not), for tests.
  int NumOptions() const { return static_cast<int>(rows_.size()); }
  // The stage groups, in pipeline order (also those that only have advanced
  // options, listed only while "Advanced" is on).
  QStringList Groups() const;
  // The "Advanced" toggle.
  QCheckBox* AdvancedToggle() const { return advanced_toggle_; }

  // Copies the editor values into the options if they are valid; else shows
  // why not and returns false.
  bool Apply();

 protected:
  void showEvent(QShowEvent* event) override;

 private:
  struct Row {
    glomap::GlobalMapperOptionEntry entry;
    QWidget* editor;
    // Index of the option's stage in the group list.
    int group_index;
  };

  // Shows or hides the advanced options (and the groups that have only
  // those).
  void ShowAdvanced(bool show);
  // Brings the editor of option `key` into view (turning "Advanced" on if
  // it is advanced), e.g. after it was refused; false for no such key.
  bool ShowOption(const std::string& key);

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
  // Per page: the box of its advanced options (null if it has none), and
  // whether it has basic options.
  std::vector<QWidget*> advanced_boxes_;
  std::vector<bool> group_has_basic_;
  QCheckBox* advanced_toggle_;
};

}  // namespace colmap
