import { render, screen, waitFor } from '@testing-library/react';
import { afterEach, describe, expect, it, vi } from 'vitest';
import { useSettingsStore, type UiConfig } from '@/stores/settingsStore';
import { StatusBar } from './StatusBar';

afterEach(() => vi.unstubAllGlobals());

function readyz(data: Record<string, unknown>) {
  const body = { status: 'ready', data: { mcp_servers: { navigation: 'connected' }, deployment: 'dev', ...data } };
  vi.stubGlobal(
    'fetch',
    vi.fn(async () => new Response(JSON.stringify(body), { status: 200 })),
  );
}

describe('status bar', () => {
  it('says which understanding is active for the planner and the chat', async () => {
    readyz({
      llm: 'rules',
      planner: 'rules',
      llm_understanding: 'rules + embedded matcher',
      planner_understanding: 'rules + embedded matcher',
      planner_state: 'ok',
    });
    render(<StatusBar />);
    const line = await screen.findByTestId('understanding');
    expect(line).toHaveTextContent('planner rules + embedded matcher · chat rules + embedded matcher · deployment dev');
  });

  it('marks a planner running on its fallback', async () => {
    readyz({
      llm: 'rules',
      planner: 'chain[anthropic,rules]',
      planner_understanding: 'rules + embedded matcher (fallback: anthropic failed)',
      planner_state: 'degraded',
    });
    render(<StatusBar />);
    await waitFor(() => expect(screen.getByText(/fallback: anthropic failed/)).toHaveClass('text-status-failed'));
  });

  it('falls back to the planner name for a brain that does not report its understanding', async () => {
    readyz({ llm: 'anthropic', planner: 'anthropic' });
    render(<StatusBar />);
    expect(await screen.findByTestId('understanding')).toHaveTextContent('planner anthropic · chat anthropic');
  });

  it('names the recognizer that hears the Talk button (issue 36)', async () => {
    readyz({ llm: 'rules', planner: 'rules' });
    const config: UiConfig = {
      deployment: 'dev',
      llm: 'rules',
      planner: 'rules',
      speech_input: true,
      speech_input_reason: null,
      speech_input_name: 'on-board recognizer (pocketsphinx)',
      speech_output_browser: true,
      camera: false,
    };
    useSettingsStore.getState().setConfig(config);
    render(<StatusBar />);
    expect(await screen.findByTestId('recognizer')).toHaveTextContent('on-board recognizer (pocketsphinx)');
    expect(screen.getByTestId('understanding')).toHaveTextContent(
      'chat rules · voice on-board recognizer (pocketsphinx) · deployment dev',
    );
  });
});
