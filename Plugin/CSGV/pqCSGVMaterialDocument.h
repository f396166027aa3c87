// SPDX-License-Identifier: MIT
/**
 * @file pqCSGVMaterialDocument.h
 * @brief Qt-side helpers on the material document (MATERIALS.md) and on the server-side
 * questions of misc/CSGVQuery, shared by the material editor and the pick panel.
 */
#ifndef pqCSGVMaterialDocument_h
#define pqCSGVMaterialDocument_h

#include <QJsonObject>
#include <QString>

class vtkSMProxy;

namespace pqCSGV
{

/// The default document (one material: every non-zero label, random colours, opaque).
QJsonObject defaultDocument();
/// The document of the CSGVMaterials text ("" or unparsable: the default document).
QJsonObject parseDocument(const QString& text, bool* ok = nullptr);
/// Compact JSON text of a document.
QString serialize(const QJsonObject& doc);
/// A new material: `label` in [1, 4294967294], constant white, opaque.
QJsonObject newMaterial(const QString& name);

/// `label` hidden: materials filtering on `label` are split around it (the volume keeps its
/// opaque pass); when a material filtering on another attribute holds it, a first material takes
/// it with opacity 0.
QString hideLabel(const QString& materials, qint64 label, const QJsonObject& attributes);
/// Only `label` visible, in the colour mode of the material that takes it now.
QString showOnlyLabel(const QString& materials, qint64 label, const QJsonObject& attributes);

/// The Segmentation Volume representation proxy behind a display (the composite's subproxy, or
/// the proxy itself); nullptr when it has none.
vtkSMProxy* segmentationProxy(vtkSMProxy* display);
/// Asks misc/CSGVQuery on the rendering process (vtkCSGVQuery.h); "" on failure.
QString query(vtkSMProxy* display, const QString& request);
/// query() parsed as a JSON object.
QJsonObject queryJson(vtkSMProxy* display, const QString& request);

/// Makes the lookup table of the display's label array categorical with each label's material
/// colour and name (a text attribute) as annotation; returns a message for the user.
QString exportLabelColors(vtkSMProxy* display);

} // namespace pqCSGV

#endif
