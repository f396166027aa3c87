// SPDX-License-Identifier: MIT
/**
 * @class pqCSGVProgressiveRendering
 * @brief GUI auto-start: keeps refining Segmentation Volumes after a still render that its time
 * budget cut short.
 *
 * A still render accumulates at most StillRenderTimeBudget seconds of frames, so path tracing on
 * a CPU device never freezes the GUI; without more renders the image would stay at the samples
 * that budget allowed. After each render of a view, this asks for another still render while a
 * visible Segmentation Volume holds fewer samples per pixel than its FramesPerStillRender and
 * renders keep adding samples (three renders in a row without progress stop it until something
 * changes); the GUI stays responsive between renders, and any interaction simply takes over.
 * CSGV_TRACE_REFINEMENT=1 prints each decision. Still renders are cut into short slices through
 * each representation's CSGVRefinementSlice property (the GUI stays answering the mouse between
 * them). Builtin sessions only: in client/server mode the sample count lives on the server, and
 * the client-side value would not tell.
 */
#ifndef pqCSGVProgressiveRendering_h
#define pqCSGVProgressiveRendering_h

#include <QMap>
#include <QSet>
#include <QObject>
#include <QPointer>

class pqRepresentation;
class pqView;

class pqCSGVProgressiveRendering : public QObject
{
  Q_OBJECT
public:
  pqCSGVProgressiveRendering(QObject* parent = nullptr);
  ~pqCSGVProgressiveRendering() override;

  void startup();
  void shutdown();

private Q_SLOTS:
  void watch(pqView* view);
  /// Gives a representation with CSGVRefinementSlice the GUI's slice.
  void slice(pqRepresentation* repr);
  void renderEnded();

private:
  /// After a still render of `view` has ended, from the event loop: asks the rendering process
  /// for the samples its volumes hold and renders again while they are below their target. Not
  /// within the render's end: a query there is a request inside the session's render (a client
  /// whose server cannot render remotely aborted: "Wrong tag", GUI re-check 12).
  void refine(pqView* view);
  QSet<pqView*> Pending; ///< views whose refine() is on its way
  QMap<pqView*, int> LastSamples;
  QMap<pqView*, int> Stalls;
  /// Views whose last render was interactive (the mouse moving): their next still render starts
  /// a new refinement, whatever its sample count (issue 38: the view stayed coarse when that
  /// render ended with as few samples as the interactive ones before it).
  QMap<pqView*, bool> AfterInteraction;
};

#endif
