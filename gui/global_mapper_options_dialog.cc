#include "gui/global_mapper_options_dialog.h"

#include <limits>
#include <utility>
#include <variant>

namespace colmap {
namespace {

// Overload set for std::visit on the table's value pointers.
template <class... Ts>
struct Overloaded : Ts... {
  using Ts::operator()...;
};
template <class... Ts>
Overloaded(Ts...) -> Overloaded<Ts...>;

// Doubles are edited as text: tolerances like 1e-6 and thresholds like 100
// share one editor, and a spin box would round the former to zero.
QString DoubleToText(double value) { return QString::number(value, 'g', 12); }

}  // namespace

GlobalMapperOptionsDialog::GlobalMapperOptionsDialog(
    QWidget* parent, glomap::GlobalMapperOptions* options,
    std::function<void()> on_accepted)
    : QDialog(parent),
      options_(options),
      on_accepted_(std::move(on_accepted)),
      edited_(*options) {
  setWindowTitle(tr("Global reconstruction options"));

  group_list_ = new QListWidget(this);
  QStackedWidget* pages = new QStackedWidget(this);
  // Per stage, a page: its basic options, then a box of its advanced ones.
  QVBoxLayout* page_layout = nullptr;
  QFormLayout* basic_form = nullptr;
  QFormLayout* advanced_form = nullptr;
  std::string current_group;
  for (const glomap::GlobalMapperOptionEntry& entry :
       glomap::GlobalMapperOptionTable(&edited_)) {
    if (page_layout == nullptr || entry.group != current_group) {
      current_group = entry.group;
      group_list_->addItem(QString::fromStdString(entry.group));
      QWidget* page = new QWidget();
      page_layout = new QVBoxLayout(page);
      QWidget* basic_part = new QWidget(page);
      basic_form = new QFormLayout(basic_part);
      basic_form->setContentsMargins(0, 0, 0, 0);
      basic_form->setFieldGrowthPolicy(QFormLayout::ExpandingFieldsGrow);
      page_layout->addWidget(basic_part);
      page_layout->addStretch(1);
      advanced_form = nullptr;
      advanced_boxes_.push_back(nullptr);
      group_has_basic_.push_back(false);
      QScrollArea* scroll = new QScrollArea(pages);
      scroll->setWidgetResizable(true);
      scroll->setWidget(page);
      pages->addWidget(scroll);
    }
    const bool basic = entry.tier == glomap::GlobalMapperOptionTier::kBasic;
    if (basic) {
      group_has_basic_.back() = true;
    } else if (advanced_form == nullptr) {
      QGroupBox* box = new QGroupBox(tr("Advanced"));
      advanced_form = new QFormLayout(box);
      advanced_form->setFieldGrowthPolicy(QFormLayout::ExpandingFieldsGrow);
      page_layout->insertWidget(1, box);
      advanced_boxes_.back() = box;
    }

    QWidget* editor = std::visit(
        Overloaded{
            [this](bool*) -> QWidget* { return new QCheckBox(this); },
            [this](int*) -> QWidget* {
              QSpinBox* spin_box = new QSpinBox(this);
              spin_box->setRange(std::numeric_limits<int>::lowest(),
                                 std::numeric_limits<int>::max());
              return spin_box;
            },
            [this](double*) -> QWidget* {
              QLineEdit* line_edit = new QLineEdit(this);
              QDoubleValidator* validator = new QDoubleValidator(line_edit);
              validator->setLocale(QLocale::c());
              validator->setNotation(QDoubleValidator::ScientificNotation);
              line_edit->setValidator(validator);
              return line_edit;
            }},
        entry.value);
    const QString tool_tip = QString::fromStdString(
        entry.help + "\n(--GlobalMapper." + entry.key + ")");
    editor->setToolTip(tool_tip);
    QLabel* label = new QLabel(QString::fromStdString(entry.key), this);
    label->setToolTip(tool_tip);
    (basic ? basic_form : advanced_form)->addRow(label, editor);
    rows_.push_back({entry, editor, group_list_->count() - 1});
  }
  group_list_->setMaximumWidth(group_list_->sizeHintForColumn(0) + 24);
  connect(group_list_, &QListWidget::currentRowChanged, pages,
          &QStackedWidget::setCurrentIndex);
  group_list_->setCurrentRow(0);

  advanced_toggle_ = new QCheckBox(tr("Advanced"), this);
  advanced_toggle_->setToolTip(
      tr("Show also the advanced options: solver and stage details (those of "
         "colmap global_mapper --help_all). Their values are kept and "
         "applied whether they are shown or not."));
  connect(advanced_toggle_, &QCheckBox::toggled, this,
          [this](bool checked) { ShowAdvanced(checked); });
  ShowAdvanced(false);

  QDialogButtonBox* buttons =
      new QDialogButtonBox(QDialogButtonBox::Ok | QDialogButtonBox::Cancel |
                               QDialogButtonBox::RestoreDefaults,
                           this);
  connect(buttons, &QDialogButtonBox::accepted, this, [this]() {
    if (Apply()) accept();
  });
  connect(buttons, &QDialogButtonBox::rejected, this, &QDialog::reject);
  connect(buttons->button(QDialogButtonBox::RestoreDefaults),
          &QPushButton::clicked, this, [this]() {
            edited_ = glomap::GlobalMapperOptions();
            ReadValues();
          });

  QHBoxLayout* body = new QHBoxLayout();
  body->addWidget(group_list_);
  body->addWidget(pages, 1);
  QHBoxLayout* bottom = new QHBoxLayout();
  bottom->addWidget(advanced_toggle_);
  bottom->addWidget(buttons, 1);
  QVBoxLayout* layout = new QVBoxLayout(this);
  layout->addLayout(body);
  layout->addLayout(bottom);
  resize(640, 480);
}

void GlobalMapperOptionsDialog::ShowAdvanced(bool show) {
  for (size_t i = 0; i < advanced_boxes_.size(); ++i) {
    if (advanced_boxes_[i] != nullptr) advanced_boxes_[i]->setVisible(show);
    group_list_->item(static_cast<int>(i))
        ->setHidden(!show && !group_has_basic_[i]);
  }
  QListWidgetItem* current = group_list_->currentItem();
  if (current == nullptr || current->isHidden()) group_list_->setCurrentRow(0);
}

bool GlobalMapperOptionsDialog::ShowOption(const std::string& key) {
  for (const Row& row : rows_) {
    if (row.entry.key != key) continue;
    if (row.entry.tier != glomap::GlobalMapperOptionTier::kBasic) {
      advanced_toggle_->setChecked(true);
    }
    group_list_->setCurrentRow(row.group_index);
    for (QWidget* parent = row.editor->parentWidget(); parent != nullptr;
         parent = parent->parentWidget()) {
      if (QScrollArea* scroll = qobject_cast<QScrollArea*>(parent)) {
        scroll->ensureWidgetVisible(row.editor);
        break;
      }
    }
    row.editor->setFocus();
    return true;
  }
  return false;
}

QStringList GlobalMapperOptionsDialog::Groups() const {
  QStringList groups;
  for (int i = 0; i < group_list_->count(); ++i) {
    groups << group_list_->item(i)->text();
  }
  return groups;
}

void GlobalMapperOptionsDialog::showEvent(QShowEvent* event) {
  edited_ = *options_;
  ReadValues();
  QDialog::showEvent(event);
}

void GlobalMapperOptionsDialog::ReadValues() {
  for (const Row& row : rows_) {
    std::visit(
        Overloaded{[&row](bool* value) {
                     static_cast<QCheckBox*>(row.editor)->setChecked(*value);
                   },
                   [&row](int* value) {
                     static_cast<QSpinBox*>(row.editor)->setValue(*value);
                   },
                   [&row](double* value) {
                     static_cast<QLineEdit*>(row.editor)
                         ->setText(DoubleToText(*value));
                   }},
        row.entry.value);
  }
}

std::vector<std::string> GlobalMapperOptionsDialog::WriteValues() {
  std::vector<std::string> invalid_keys;
  for (const Row& row : rows_) {
    std::visit(
        Overloaded{[&row](bool* value) {
                     *value = static_cast<QCheckBox*>(row.editor)->isChecked();
                   },
                   [&row](int* value) {
                     *value = static_cast<QSpinBox*>(row.editor)->value();
                   },
                   [&row, &invalid_keys](double* value) {
                     bool ok = false;
                     const double parsed = QLocale::c().toDouble(
                         static_cast<QLineEdit*>(row.editor)->text().trimmed(),
                         &ok);
                     if (ok) {
                       *value = parsed;
                     } else {
                       invalid_keys.push_back(row.entry.key);
                     }
                   }},
        row.entry.value);
  }
  return invalid_keys;
}

bool GlobalMapperOptionsDialog::Apply() {
  // `edited_` was copied from the options when the dialog opened, so fields
  // without an editor (image_path, the image list) keep their values.
  const std::vector<std::string> invalid_keys = WriteValues();
  if (!invalid_keys.empty()) {
    ShowOption(invalid_keys.front());
    QMessageBox::critical(this, windowTitle(),
                          QString::fromStdString("Not a number: GlobalMapper." +
                                                 invalid_keys.front()));
    return false;
  }
  if (const glomap::Status check = edited_.Check(); !check.ok()) {
    // The message starts with the option's name: "GlobalMapper.<key> must
    // be ..."; options that are not in the dialog are not shown.
    const std::string& message = check.message();
    const std::string prefix = "GlobalMapper.";
    if (message.rfind(prefix, 0) == 0) {
      ShowOption(
          message.substr(prefix.size(), message.find(' ') - prefix.size()));
    }
    QMessageBox::critical(this, windowTitle(), QString::fromStdString(message));
    return false;
  }
  *options_ = edited_;
  if (on_accepted_) on_accepted_();
  return true;
}

}  // namespace colmap
