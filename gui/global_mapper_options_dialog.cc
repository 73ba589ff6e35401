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
  QFormLayout* page_layout = nullptr;
  std::string current_group;
  for (const glomap::GlobalMapperOptionEntry& entry :
       glomap::GlobalMapperOptionTable(&edited_)) {
    if (page_layout == nullptr || entry.group != current_group) {
      current_group = entry.group;
      group_list_->addItem(QString::fromStdString(entry.group));
      QWidget* page = new QWidget();
      page_layout = new QFormLayout(page);
      page_layout->setFieldGrowthPolicy(QFormLayout::ExpandingFieldsGrow);
      QScrollArea* scroll = new QScrollArea(pages);
      scroll->setWidgetResizable(true);
      scroll->setWidget(page);
      pages->addWidget(scroll);
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
    page_layout->addRow(label, editor);
    rows_.push_back({entry, editor});
  }
  group_list_->setMaximumWidth(group_list_->sizeHintForColumn(0) + 24);
  connect(group_list_, &QListWidget::currentRowChanged, pages,
          &QStackedWidget::setCurrentIndex);
  group_list_->setCurrentRow(0);

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
  QVBoxLayout* layout = new QVBoxLayout(this);
  layout->addLayout(body);
  layout->addWidget(buttons);
  resize(640, 480);
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
    QMessageBox::critical(this, windowTitle(),
                          QString::fromStdString("Not a number: GlobalMapper." +
                                                 invalid_keys.front()));
    return false;
  }
  if (const glomap::Status check = edited_.Check(); !check.ok()) {
    QMessageBox::critical(this, windowTitle(),
                          QString::fromStdString(check.message()));
    return false;
  }
  *options_ = edited_;
  if (on_accepted_) on_accepted_();
  return true;
}

}  // namespace colmap
