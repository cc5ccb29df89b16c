// Drawing the viewport only when it changed.

#include "app/gui/render_gate.h"

#include <vtkCamera.h>
#include <vtkLight.h>
#include <vtkLightCollection.h>
#include <vtkProp.h>
#include <vtkPropCollection.h>
#include <vtkRenderWindow.h>
#include <vtkRenderer.h>
#include <vtkRendererCollection.h>

#include <algorithm>

namespace palpa::app {

vtkMTimeType RenderGate::scene_time() const {
  vtkMTimeType t = 0;
  vtkRendererCollection* renderers = window_->GetRenderers();
  vtkCollectionSimpleIterator rit;
  renderers->InitTraversal(rit);
  while (vtkRenderer* r = renderers->GetNextRenderer(rit)) {
    t = std::max(t, r->GetMTime());
    if (vtkCamera* c = r->GetActiveCamera()) t = std::max(t, c->GetMTime());
    vtkLightCollection* lights = r->GetLights();
    vtkCollectionSimpleIterator lit;
    lights->InitTraversal(lit);
    while (vtkLight* l = lights->GetNextLight(lit)) t = std::max(t, l->GetMTime());
    vtkPropCollection* props = r->GetViewProps();
    vtkCollectionSimpleIterator pit;
    props->InitTraversal(pit);
    while (vtkProp* p = props->GetNextProp(pit)) t = std::max(t, p->GetRedrawMTime());
  }
  return t;
}

bool RenderGate::draw_if_needed() {
  if (!pending_ && scene_time() <= drawn_at_) return false;
  draw();
  return true;
}

void RenderGate::draw() {
  const vtkMTimeType before = scene_time();
  window_->Render();
  ++draws_;
  const vtkMTimeType after = scene_time();
  // Drawing may adjust the scene itself (the camera's clipping range to
  // what is drawn now): then one more draw shows the scene as adjusted, but
  // not another for an adjustment that draw makes again.
  pending_ = after != before && !settling_;
  settling_ = pending_;
  drawn_at_ = after;
}

}  // namespace palpa::app
