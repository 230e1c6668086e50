function [text, name] = scene_text(scene)
% scene_text  A scene given as a struct or a scene file's name, as the text the C library reads
%   and the name its errors use (internal to +mdr).
  if ischar(scene)
    text = fileread(scene);
    name = scene;
  elseif isstruct(scene) && isscalar(scene)
    text = mdr.internal.to_json(struct('scene', scene));
    name = 'scene';
  else
    error('mdr:invalidArgument', 'scene: must be a struct or a scene file name');
  end
end
